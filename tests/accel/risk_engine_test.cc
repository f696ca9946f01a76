// The RiskEngine on the CPU path: exact results in order for any batch size,
// any number of workers and callers, with and without callers running
// chunks; and planner runs through it identical to direct evaluation.
#include "accel/risk_engine.h"

#include <thread>
#include <vector>

#include "accel_test_util.h"
#include "core/planners/planner.h"
#include "gtest/gtest.h"

namespace riskplan::accel {
namespace {

using testing::MixedConfigs;
using testing::SameRisk;
using testing::SmallCity;

void ExpectExact(RiskEngine& engine, const RiskModel& model, const std::vector<Pose>& configs) {
  std::vector<ConfigurationRisk> out(configs.size());
  for (ConfigurationRisk& r : out) r.risk = -1.0;  // sentinel: never a result
  ASSERT_TRUE(engine.Evaluate(model, configs, out).ok());
  for (size_t n = 0; n < configs.size(); ++n) {
    ASSERT_TRUE(SameRisk(out[n], model.Evaluate(configs[n]))) << "configuration " << n;
  }
}

struct EngineCase {
  int cpu_workers;
  bool caller_runs;
};

class RiskEngineCpuTest : public ::testing::TestWithParam<EngineCase> {};

TEST_P(RiskEngineCpuTest, ExactAndInOrderForEveryBatchSize) {
  RiskEngineOptions options;
  options.cpu_workers = GetParam().cpu_workers;
  options.caller_runs = GetParam().caller_runs;
  options.min_chunk_configs = 100;
  auto engine = RiskEngine::Create(options);
  ASSERT_TRUE(engine.ok()) << engine.status();
  const RiskModel& model = *SmallCity();
  const std::vector<Pose> all = MixedConfigs(model, 30000, 3);
  for (size_t n : {size_t{1}, size_t{99}, size_t{100}, size_t{101}, size_t{2500}, size_t{30000}}) {
    ExpectExact(**engine, model, std::vector<Pose>(all.begin(), all.begin() + n));
  }
  const RiskEngineStats stats = (*engine)->Stats();
  EXPECT_EQ(stats.batches, 6u);
  uint64_t by_workers = stats.caller_configurations;
  for (const CpuWorkerStats& w : stats.cpu) by_workers += w.configurations;
  // Every configuration was evaluated exactly once.
  EXPECT_EQ(by_workers, stats.configurations);
  if (!GetParam().caller_runs && GetParam().cpu_workers > 0) {
    EXPECT_EQ(stats.caller_chunks, 0u);
  }
}

INSTANTIATE_TEST_SUITE_P(Pools, RiskEngineCpuTest,
                         ::testing::Values(EngineCase{0, true}, EngineCase{0, false},
                                           EngineCase{1, true}, EngineCase{2, false},
                                           EngineCase{3, true}));

TEST(RiskEngineTest, ManyCallersAtOnce) {
  RiskEngineOptions options;
  options.cpu_workers = 2;
  options.min_chunk_configs = 64;
  auto engine = RiskEngine::Create(options);
  ASSERT_TRUE(engine.ok());
  const RiskModel& model = *SmallCity();
  std::vector<std::thread> callers;
  for (int t = 0; t < 6; ++t) {
    callers.emplace_back([&, t] {
      for (int round = 0; round < 5; ++round) {
        ExpectExact(**engine, model, MixedConfigs(model, 500 + 700 * t, 100 * t + round));
      }
    });
  }
  for (std::thread& t : callers) t.join();
}

TEST(RiskEngineTest, RefusesMismatchedSpansAndBadOptions) {
  auto engine = RiskEngine::Create({});
  ASSERT_TRUE(engine.ok());
  std::vector<Pose> configs(3);
  std::vector<ConfigurationRisk> out(2);
  EXPECT_EQ((*engine)->Evaluate(*SmallCity(), configs, out).code(),
            absl::StatusCode::kInvalidArgument);
  RiskEngineOptions bad;
  bad.cpu_workers = -1;
  EXPECT_FALSE(RiskEngine::Create(bad).ok());
  bad = {};
  bad.fpga_shims = {"no-port"};
  EXPECT_FALSE(RiskEngine::Create(bad).ok());
}

TEST(RiskEngineTest, AnUnreachableBoardLeavesTheCpuToAnswer) {
  // Port 1 on the loopback refuses connections.
  RiskEngineOptions options;
  options.cpu_workers = 0;
  options.caller_runs = false;
  options.fpga_shims = {"127.0.0.1:1"};
  options.fpga.backoff_initial = absl::Milliseconds(5);
  options.fpga.backoff_max = absl::Milliseconds(20);
  std::vector<WorkerEvent> events;
  absl::Mutex mu;
  options.on_worker_event = [&](const WorkerEvent& e) {
    absl::MutexLock lock(&mu);
    events.push_back(e);
  };
  auto engine = RiskEngine::Create(options);
  ASSERT_TRUE(engine.ok());
  const RiskModel& model = *SmallCity();
  ExpectExact(**engine, model, MixedConfigs(model, 5000, 9));
  ASSERT_TRUE(testing::WaitFor([&] {
    absl::MutexLock lock(&mu);
    return events.size() >= 3;  // down, probing, down, ...
  }));
  const RiskEngineStats stats = (*engine)->Stats();
  ASSERT_EQ(stats.fpga.size(), 1u);
  EXPECT_NE(stats.fpga[0].state, WorkerState::kUp);
  EXPECT_EQ(stats.fpga[0].chunks, 0u);
  absl::MutexLock lock(&mu);
  EXPECT_EQ(events[0].worker, "fpga:127.0.0.1:1");
  EXPECT_EQ(events[0].to, WorkerState::kDown);
  EXPECT_NE(events[0].reason.find("probe failed"), std::string::npos);
}

TEST(RiskEngineTest, PlansThroughTheEngineEqualDirectPlans) {
  RiskEngineOptions options;
  options.cpu_workers = 2;
  options.min_chunk_configs = 32;
  auto engine = RiskEngine::Create(options);
  ASSERT_TRUE(engine.ok());
  const std::shared_ptr<const RiskModel> model = SmallCity();
  const RiskMap& m = model->map();
  PlanningProblem problem;
  problem.model = model;
  const auto pose = [&](double x, double y, double theta) {
    int i = 0, j = 0;
    m.CellOf(x, y, &i, &j);
    return Pose{x, y, model->SafeAltitude(i, j) + 20.0, theta};
  };
  problem.start = pose(m.x0() + 400.0, m.y0() + 500.0, 0.3);
  problem.goal = pose(m.x0() + 2500.0, m.y0() + 2400.0, 0.9);
  PlanOptions plan_options;
  plan_options.budget.max_time_s = 0.0;
  plan_options.budget.max_iterations = 300;
  plan_options.seed = 17;
  CancellationToken cancel;
  auto direct = MakePlanner(PlannerAlgorithm::kRiskRrtStar);
  ASSERT_TRUE(direct.ok());
  auto want = (*direct)->Plan(problem, plan_options, cancel, nullptr);
  ASSERT_TRUE(want.ok()) << want.status();
  std::unique_ptr<RiskEvaluator> evaluator = (*engine)->NewEvaluator();
  auto through = MakePlanner(PlannerAlgorithm::kRiskRrtStar, evaluator.get());
  ASSERT_TRUE(through.ok());
  auto got = (*through)->Plan(problem, plan_options, cancel, nullptr);
  ASSERT_TRUE(got.ok()) << got.status();
  ASSERT_EQ(got->best.has_value(), want->best.has_value());
  if (want->best) {
    EXPECT_EQ(got->best->risk, want->best->risk);
    ASSERT_EQ(got->best->waypoints.size(), want->best->waypoints.size());
    for (size_t w = 0; w < want->best->waypoints.size(); ++w) {
      EXPECT_EQ(got->best->waypoints[w].x, want->best->waypoints[w].x);
      EXPECT_EQ(got->best->waypoints[w].y, want->best->waypoints[w].y);
      EXPECT_EQ(got->best->waypoints[w].z, want->best->waypoints[w].z);
    }
  }
  EXPECT_EQ(got->tree_size, want->tree_size);
  EXPECT_EQ(evaluator->evaluated(), got->configurations_evaluated);
  EXPECT_GT(evaluator->evaluated(), 0u);
}

}  // namespace
}  // namespace riskplan::accel
