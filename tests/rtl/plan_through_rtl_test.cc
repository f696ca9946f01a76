// A plan served through riskplan-fpga-shim with the `verilator` backend (the
// RTL simulated cycle by cycle) completes and gives the `model` backend's
// trajectory, waypoint for waypoint and risk for risk: both compute the same
// exact fixed-point sums (rtl_component_test checks that site by site), so
// every comparison the planner makes comes out the same. Every batch goes to
// the board (no CPU workers, the caller never runs a chunk), so no result
// comes from the CPU.
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

#include "accel/risk_engine.h"
#include "gtest/gtest.h"
#include "tests/accel/accel_test_util.h"
#include "tests/accel/plan_test_util.h"

namespace riskplan::accel {
namespace {

using testing::PlanWith;
using testing::Problems;
using testing::SameWaypoints;
using testing::ShimProcess;

// The simulation runs about a million clocks a second and a plan of 100
// samples asks for about 7 million: enough to exercise every part of the
// path (kernel slots, shared cuts, many jobs) in a test of reasonable length.
constexpr int kIterations = 100;

struct BoardRun {
  std::vector<PlanResult> plans;
  uint64_t device_cycles = 0;
  std::string backend;
  uint32_t lanes = 0;
};

BoardRun PlanThroughShim(const std::vector<std::string>& args,
                         const std::vector<PlanningProblem>& problems, int iterations) {
  BoardRun run;
  auto shim = ShimProcess::Start(args);
  EXPECT_NE(shim, nullptr);
  if (shim == nullptr) return run;
  std::unique_ptr<RiskEngine> engine = testing::BoardOnlyEngine(shim->endpoint());
  if (engine == nullptr) return run;
  for (const PlanningProblem& problem : problems) {
    std::unique_ptr<RiskEvaluator> evaluator = engine->NewEvaluator();
    auto plan = PlanWith(evaluator.get(), problem, iterations);
    EXPECT_TRUE(plan.ok()) << plan.status();
    run.plans.push_back(plan.ok() ? *std::move(plan) : PlanResult{});
  }
  const RiskEngineStats stats = engine->Stats();
  EXPECT_EQ(stats.caller_configurations, 0u);
  run.device_cycles = stats.fpga[0].device_cycles;
  run.backend = stats.fpga[0].hello.backend;
  run.lanes = stats.fpga[0].hello.lanes;
  return run;
}

void ExpectSamePlans(const BoardRun& rtl, const BoardRun& model) {
  ASSERT_EQ(rtl.plans.size(), model.plans.size());
  for (size_t p = 0; p < rtl.plans.size(); ++p) {
    ASSERT_TRUE(rtl.plans[p].best.has_value()) << "scenario " << p << ": no trajectory";
    ASSERT_TRUE(model.plans[p].best.has_value()) << "scenario " << p;
    EXPECT_TRUE(SameWaypoints(rtl.plans[p], model.plans[p])) << "scenario " << p;
    const double a = rtl.plans[p].best->risk, b = model.plans[p].best->risk;
    EXPECT_EQ(std::memcmp(&a, &b, sizeof a), 0) << "scenario " << p << ": " << a << " vs " << b;
    EXPECT_EQ(rtl.plans[p].iterations, model.plans[p].iterations);
  }
}

TEST(PlanThroughRtlTest, BoardBuildGivesTheModelBackendsTrajectories) {
  std::vector<PlanningProblem> problems = Problems();
  problems.resize(2);
  const BoardRun rtl =
      PlanThroughShim({"--device=verilator", "--rtl_config=l8-board"}, problems, kIterations);
  const BoardRun model =
      PlanThroughShim({"--device=model", "--format=board"}, problems, kIterations);
  EXPECT_EQ(rtl.backend, "verilator");
  EXPECT_EQ(rtl.lanes, 8u);
  EXPECT_EQ(model.backend, "model");
  ExpectSamePlans(rtl, model);
  // The RTL reports the cycles its jobs took; the software model reports none.
  EXPECT_GT(rtl.device_cycles, 0u);
  EXPECT_EQ(model.device_cycles, 0u);
  std::cout << "RTL: " << rtl.device_cycles << " component cycles for " << problems.size()
            << " plans\n";
}

TEST(PlanThroughRtlTest, PreciseBuildGivesTheModelBackendsTrajectories) {
  std::vector<PlanningProblem> problems = Problems();
  problems.resize(1);
  const BoardRun rtl =
      PlanThroughShim({"--device=verilator", "--rtl_config=l16-precise"}, problems, kIterations);
  const BoardRun model =
      PlanThroughShim({"--device=model", "--format=precise"}, problems, kIterations);
  EXPECT_EQ(rtl.lanes, 16u);
  ExpectSamePlans(rtl, model);
}

}  // namespace
}  // namespace riskplan::accel
