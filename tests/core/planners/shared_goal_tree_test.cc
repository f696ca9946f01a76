#include "core/planners/shared_goal_tree.h"

#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <thread>
#include <utility>
#include <vector>

#include "core/map/demo_city.h"
#include "core/planners/risk_rrt_star_run.h"
#include "gtest/gtest.h"
#include "tests/core/planner_test_util.h"

namespace riskplan {
namespace {

using testing_planner::FindFlyablePose;
using testing_planner::ReEvaluate;
using testing_planner::Scenario;

constexpr double kInf = std::numeric_limits<double>::infinity();

// Everything one shared-tree plan reported, in the order it was reported.
struct FleetOutcome {
  absl::StatusOr<std::vector<absl::StatusOr<PlanResult>>> results;
  std::vector<std::pair<size_t, PlanImprovement>> improvements;
  std::vector<size_t> completion_order;
  std::vector<absl::StatusOr<PlanResult>> streamed;  // as on_result saw them, by index
};

SharedTreeMission IterationMission(const Pose& start, int64_t iterations) {
  SharedTreeMission m;
  m.start = start;
  m.budget.max_time_s = 0.0;
  m.budget.max_iterations = iterations;
  return m;
}

FleetOutcome RunFleet(const SharedTreeProblem& problem, uint64_t seed,
                      std::map<std::string, double> params = {},
                      const CancellationToken* token = nullptr,
                      std::function<void(size_t, const PlanImprovement&)> also = nullptr) {
  FleetOutcome out;
  out.streamed.assign(problem.missions.size(), absl::UnknownError("no result streamed"));
  SharedTreeOptions options;
  options.seed = seed;
  options.params = std::move(params);
  CancellationToken own;
  SharedGoalTreePlanner planner;
  out.results = planner.Plan(
      problem, options, token != nullptr ? *token : own,
      [&](size_t m, const PlanImprovement& i) {
        out.improvements.push_back({m, i});
        if (also) also(m, i);
      },
      [&](size_t m, const absl::StatusOr<PlanResult>& r) {
        out.completion_order.push_back(m);
        out.streamed[m] = r;
      });
  return out;
}

void ExpectSamePoses(const std::vector<Pose>& a, const std::vector<Pose>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].x, b[i].x);
    EXPECT_EQ(a[i].y, b[i].y);
    EXPECT_EQ(a[i].z, b[i].z);
    EXPECT_EQ(a[i].theta, b[i].theta);
  }
}

// A depot in demo-city's south-east suburbs and starts scattered around the
// city, most of them across the centre from it.
class SharedGoalTreeTest : public testing_planner::DemoCityPlannerTest {
 protected:
  static void SetUpTestSuite() {
    DemoCityPlannerTest::SetUpTestSuite();
    depot_ = *FindFlyablePose(*model_, 6500, 1500, kPi / 2);
    const double spots[][3] = {{1200, 6500, 0.0}, {1500, 2500, 0.5}, {4000, 7000, 4.7},
                               {7000, 6500, 4.0}, {2500, 4200, 1.0}, {5200, 5200, 5.5},
                               {800, 1000, 0.3},  {3500, 1200, 6.0}};
    for (const auto& s : spots) starts_.push_back(*FindFlyablePose(*model_, s[0], s[1], s[2]));
  }
  static SharedTreeProblem Problem(const std::vector<int64_t>& iterations) {
    SharedTreeProblem p;
    p.model = model_;
    p.goal = depot_;
    for (size_t k = 0; k < iterations.size(); ++k) {
      p.missions.push_back(IterationMission(starts_[k % starts_.size()], iterations[k]));
    }
    return p;
  }
  static Pose depot_;
  static std::vector<Pose> starts_;
};
Pose SharedGoalTreeTest::depot_;
std::vector<Pose> SharedGoalTreeTest::starts_;

// Every improvement of every mission, and every final result, carries
// exactly the risk an independent EvaluateTrajectory gives its waypoints,
// flies from that mission's own start to the shared goal, and improves on the
// mission's previous one.
TEST_F(SharedGoalTreeTest, EveryReportedRiskIsEvaluateTrajectorysBitForBit) {
  const SharedTreeProblem problem = Problem({400, 250, 400, 300, 350, 400});
  FleetOutcome out = RunFleet(problem, 3);
  ASSERT_TRUE(out.results.ok()) << out.results.status();
  std::vector<double> last(problem.missions.size(), kInf);
  std::vector<int> count(problem.missions.size(), 0);
  for (const auto& [m, i] : out.improvements) {
    SCOPED_TRACE(testing::Message() << "mission " << m << " at iteration " << i.iterations);
    bool admissible = false;
    EXPECT_EQ(i.risk, ReEvaluate(*model_, i.waypoints, &admissible));
    EXPECT_TRUE(admissible);
    EXPECT_LT(i.risk, last[m]);
    last[m] = i.risk;
    ++count[m];
    ExpectSamePoses({i.waypoints.front(), i.waypoints.back()}, {problem.missions[m].start, depot_});
  }
  for (size_t m = 0; m < problem.missions.size(); ++m) {
    SCOPED_TRACE(testing::Message() << "mission " << m);
    const absl::StatusOr<PlanResult>& r = (*out.results)[m];
    ASSERT_TRUE(r.ok()) << r.status();
    ASSERT_TRUE(r->best.has_value());
    EXPECT_EQ(r->reason, StopReason::kBudgetExhausted);
    EXPECT_EQ(r->iterations, problem.missions[m].budget.max_iterations);
    EXPECT_EQ(r->best->risk, last[m]);  // the last improvement is the result
    EXPECT_GT(count[m], 0);
    bool admissible = false;
    EXPECT_EQ(r->best->risk, ReEvaluate(*model_, r->best->waypoints, &admissible));
    EXPECT_TRUE(admissible);
    EXPECT_GT(r->best->risk, 0.0);
    // The streamed result is the returned one.
    ASSERT_TRUE(out.streamed[m].ok());
    EXPECT_EQ(out.streamed[m]->best->risk, r->best->risk);
  }
}

TEST_F(SharedGoalTreeTest, SameMissionsAndSeedGiveTheSameTrajectoriesBitForBit) {
  const SharedTreeProblem problem = Problem({300, 500, 200, 500, 400});
  FleetOutcome a = RunFleet(problem, 42);
  FleetOutcome b = RunFleet(problem, 42);
  ASSERT_TRUE(a.results.ok() && b.results.ok());
  EXPECT_EQ(a.completion_order, b.completion_order);
  ASSERT_EQ(a.improvements.size(), b.improvements.size());
  for (size_t k = 0; k < a.improvements.size(); ++k) {
    EXPECT_EQ(a.improvements[k].first, b.improvements[k].first);
    EXPECT_EQ(a.improvements[k].second.risk, b.improvements[k].second.risk);
    EXPECT_EQ(a.improvements[k].second.iterations, b.improvements[k].second.iterations);
  }
  for (size_t m = 0; m < problem.missions.size(); ++m) {
    SCOPED_TRACE(testing::Message() << "mission " << m);
    const auto& ra = (*a.results)[m];
    const auto& rb = (*b.results)[m];
    ASSERT_TRUE(ra.ok() && rb.ok());
    ASSERT_TRUE(ra->best.has_value() && rb->best.has_value());
    EXPECT_EQ(ra->best->risk, rb->best->risk);
    EXPECT_EQ(ra->tree_size, rb->tree_size);
    EXPECT_EQ(ra->configurations_evaluated, rb->configurations_evaluated);
    ExpectSamePoses(ra->best->waypoints, rb->best->waypoints);
  }
  // Another seed explores otherwise.
  FleetOutcome c = RunFleet(problem, 43);
  ASSERT_TRUE(c.results.ok());
  ASSERT_TRUE((*c.results)[1].ok() && (*c.results)[1]->best.has_value());
  EXPECT_NE((*a.results)[1]->best->risk, (*c.results)[1]->best->risk);
}

// The single-start planner is the one-mission case: the same seed gives the
// same improvements and result bit for bit, with and without the guide and
// the refinement.
TEST_F(SharedGoalTreeTest, OneMissionIsRiskRrtStarBitForBit) {
  const std::map<std::string, double> variants[] = {
      {}, {{"guide_cell_m", 0.0}, {"refine_edits", 0.0}}, {{"batch_chunk", 0.0}}};
  int compared = 0;
  for (size_t k = 0; k < scenarios_.size(); k += 8) {
    for (const auto& params : variants) {
      const Scenario& sc = scenarios_[k];
      SCOPED_TRACE(testing::Message() << sc.name << " with " << params.size() << " parameters");
      auto planner = MakePlanner(PlannerAlgorithm::kRiskRrtStar);
      ASSERT_TRUE(planner.ok());
      PlanOptions options;
      options.budget.max_time_s = 0.0;
      options.budget.max_iterations = 300;
      options.seed = 5 + k;
      options.params = params;
      CancellationToken cancel;
      std::vector<PlanImprovement> single_improvements;
      auto single =
          (*planner)->Plan({model_, sc.start, sc.goal}, options, cancel,
                           [&](const PlanImprovement& i) { single_improvements.push_back(i); });
      ASSERT_TRUE(single.ok()) << single.status();

      SharedTreeProblem problem;
      problem.model = model_;
      problem.goal = sc.goal;
      problem.missions.push_back(IterationMission(sc.start, 300));
      FleetOutcome fleet = RunFleet(problem, 5 + k, params);
      ASSERT_TRUE(fleet.results.ok()) << fleet.results.status();
      const absl::StatusOr<PlanResult>& shared = (*fleet.results)[0];
      ASSERT_TRUE(shared.ok()) << shared.status();

      EXPECT_EQ(shared->reason, single->reason);
      EXPECT_EQ(shared->iterations, single->iterations);
      EXPECT_EQ(shared->tree_size, single->tree_size);
      EXPECT_EQ(shared->configurations_evaluated, single->configurations_evaluated);
      ASSERT_EQ(shared->best.has_value(), single->best.has_value());
      if (single->best.has_value()) {
        EXPECT_EQ(shared->best->risk, single->best->risk);
        EXPECT_EQ(shared->best->length_m, single->best->length_m);
        ExpectSamePoses(shared->best->waypoints, single->best->waypoints);
      }
      ASSERT_EQ(fleet.improvements.size(), single_improvements.size());
      for (size_t i = 0; i < single_improvements.size(); ++i) {
        EXPECT_EQ(fleet.improvements[i].second.risk, single_improvements[i].risk);
        EXPECT_EQ(fleet.improvements[i].second.iterations, single_improvements[i].iterations);
      }
      ++compared;
    }
  }
  EXPECT_GE(compared, 9);
}

TEST_F(SharedGoalTreeTest, ABadStartGetsItsOwnErrorWhileTheOthersArePlanned) {
  SharedTreeProblem problem = Problem({200, 200, 200, 200, 200, 200});
  problem.missions[1].start.z = model_->map().terrain(0, 0) - 50.0;  // below ground
  problem.missions[2].start.x = -100.0;                              // off the map
  problem.missions[4].start.theta = std::nan("");
  problem.missions[5].budget.max_iterations = 0;  // and no time: no budget
  FleetOutcome out = RunFleet(problem, 1);
  ASSERT_TRUE(out.results.ok()) << out.results.status();
  const auto& r = *out.results;
  const struct {
    size_t mission;
    const char* says;
  } errors[] = {{1, "missions[1]: start pose"},
                {2, "OUTSIDE_MAP"},
                {4, "missions[4]: start.theta"},
                {5, "missions[5]: budget"}};
  for (const auto& e : errors) {
    SCOPED_TRACE(e.mission);
    ASSERT_FALSE(r[e.mission].ok());
    EXPECT_EQ(r[e.mission].status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(r[e.mission].status().message().find(e.says), std::string::npos)
        << r[e.mission].status();
  }
  for (size_t m : {0, 3}) {
    ASSERT_TRUE(r[m].ok()) << r[m].status();
    ASSERT_TRUE(r[m]->best.has_value());
    bool admissible = false;
    EXPECT_EQ(r[m]->best->risk, ReEvaluate(*model_, r[m]->best->waypoints, &admissible));
  }
  // The errors come first, before any planning, then the planned missions.
  EXPECT_EQ(out.completion_order, (std::vector<size_t>{1, 2, 4, 5, 0, 3}));
  for (const auto& [m, i] : out.improvements) EXPECT_TRUE(m == 0 || m == 3) << m;
}

TEST_F(SharedGoalTreeTest, WhatAllMissionsShareIsCheckedForTheWholePlan) {
  SharedGoalTreePlanner planner;
  CancellationToken cancel;
  SharedTreeOptions options;
  SharedTreeProblem bad_goal = Problem({10, 10});
  bad_goal.goal.z += 1000.0;
  auto r = planner.Plan(bad_goal, options, cancel, nullptr, nullptr);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("goal pose"), std::string::npos) << r.status();
  EXPECT_NE(r.status().message().find("ABOVE_MAX_ALTITUDE"), std::string::npos) << r.status();

  r = planner.Plan(Problem({}), options, cancel, nullptr, nullptr);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("missions: none"), std::string::npos) << r.status();

  r = planner.Plan(Problem(std::vector<int64_t>(kMaxSharedTreeMissions + 1, 10)), options, cancel,
                   nullptr, nullptr);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("at most 256"), std::string::npos) << r.status();

  SharedTreeOptions bad_param;
  bad_param.params = {{"step_m", 1.0}};
  r = planner.Plan(Problem({10}), bad_param, cancel, nullptr, nullptr);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("step_m"), std::string::npos) << r.status();

  // The edge-sample bound is each start's: with a limit no plan meets, every
  // mission gets its own error and nothing is planned.
  SharedTreeOptions tight;
  tight.max_edge_samples = 10;
  std::vector<size_t> order;
  r = planner.Plan(Problem({10, 10}), tight, cancel, nullptr,
                   [&](size_t m, const absl::StatusOr<PlanResult>&) { order.push_back(m); });
  ASSERT_TRUE(r.ok()) << r.status();
  for (size_t m : {0, 1}) {
    ASSERT_FALSE((*r)[m].ok());
    EXPECT_NE((*r)[m].status().message().find("samples per edge"), std::string::npos)
        << (*r)[m].status();
  }
  EXPECT_EQ(order, (std::vector<size_t>{0, 1}));
}

// Each mission ends when its own budget does, with its result then, while
// the tree grows on for the others; missions that end together come in index
// order. A time budget that has already passed ends its mission at once.
TEST_F(SharedGoalTreeTest, CompletionOrderFollowsTheBudgets) {
  SharedTreeProblem problem = Problem({300, 100, 200, 100, 250});
  SharedTreeMission timed;
  timed.start = starts_[5];
  timed.budget.max_time_s = 1e-9;
  problem.missions.push_back(timed);
  FleetOutcome out = RunFleet(problem, 9);
  ASSERT_TRUE(out.results.ok()) << out.results.status();
  EXPECT_EQ(out.completion_order, (std::vector<size_t>{5, 1, 3, 2, 4, 0}));
  const auto& r = *out.results;
  ASSERT_TRUE(r[5].ok());
  EXPECT_EQ(r[5]->reason, StopReason::kNoSolution);
  EXPECT_EQ(r[5]->iterations, 0);
  int64_t previous_tree = 0;
  for (size_t m : {1, 3, 2, 4, 0}) {
    SCOPED_TRACE(m);
    ASSERT_TRUE(r[m].ok()) << r[m].status();
    EXPECT_EQ(r[m]->iterations, problem.missions[m].budget.max_iterations);
    EXPECT_GE(r[m]->tree_size, previous_tree);  // the tree kept growing
    previous_tree = r[m]->tree_size;
  }
  // No improvement of a mission after its result.
  for (const auto& [m, i] : out.improvements) {
    if (m == 5) ADD_FAILURE() << "the timed mission had no time to improve";
    EXPECT_LE(i.iterations, problem.missions[m].budget.max_iterations);
  }
}

// Cancelling ends every running mission CANCELLED, keeping its best so far;
// a mission whose budget had already ended keeps its own result.
TEST_F(SharedGoalTreeTest, CancellationEndsEveryRunningMission) {
  SharedTreeProblem problem = Problem({20, 3000, 3000, 3000});
  CancellationToken cancel;
  int64_t cancelled_at = -1;
  FleetOutcome out = RunFleet(problem, 4, {}, &cancel, [&](size_t, const PlanImprovement& i) {
    if (i.iterations > 40 && cancelled_at < 0) {
      cancelled_at = i.iterations;
      cancel.Cancel();
    }
  });
  ASSERT_TRUE(out.results.ok()) << out.results.status();
  ASSERT_GT(cancelled_at, 40);
  const auto& r = *out.results;
  ASSERT_TRUE(r[0].ok());
  EXPECT_EQ(r[0]->reason, StopReason::kBudgetExhausted);
  EXPECT_EQ(r[0]->iterations, 20);
  for (size_t m : {1, 2, 3}) {
    SCOPED_TRACE(m);
    ASSERT_TRUE(r[m].ok()) << r[m].status();
    EXPECT_EQ(r[m]->reason, StopReason::kCancelled);
    EXPECT_EQ(r[m]->iterations, cancelled_at);
    EXPECT_TRUE(r[m]->best.has_value());
  }
  EXPECT_EQ(out.completion_order, (std::vector<size_t>{0, 1, 2, 3}));
}

TEST_F(SharedGoalTreeTest, CancellationFromAnotherThreadStopsEveryMissionPromptly) {
  SharedTreeProblem problem;
  problem.model = model_;
  problem.goal = depot_;
  for (size_t k = 0; k < 4; ++k) {
    SharedTreeMission m;
    m.start = starts_[k];
    m.budget.max_time_s = 600.0;  // would run for ten minutes
    problem.missions.push_back(m);
  }
  CancellationToken cancel;
  std::chrono::steady_clock::time_point cancelled;
  std::thread canceller([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    cancelled = std::chrono::steady_clock::now();
    cancel.Cancel();
  });
  FleetOutcome out = RunFleet(problem, 1, {}, &cancel);
  const auto returned = std::chrono::steady_clock::now();
  canceller.join();
  ASSERT_TRUE(out.results.ok());
  for (const auto& r : *out.results) {
    ASSERT_TRUE(r.ok()) << r.status();
    EXPECT_EQ(r->reason, StopReason::kCancelled);
  }
  // Behaviour, not speed: a step takes milliseconds, the budget ten minutes.
  EXPECT_LT(std::chrono::duration<double>(returned - cancelled).count(), 5.0);
}

// The node bound is the shared tree's: reaching it ends every mission.
TEST_F(SharedGoalTreeTest, MaxNodesEndsEveryMission) {
  const SharedTreeProblem problem = Problem({100000, 100000, 100000});
  FleetOutcome out = RunFleet(problem, 2, {{"max_nodes", 150}});
  ASSERT_TRUE(out.results.ok());
  for (const auto& r : *out.results) {
    ASSERT_TRUE(r.ok()) << r.status();
    EXPECT_LT(r->iterations, 100000);
    // Checked between steps: one step (a guide route) may pass it by its nodes.
    EXPECT_GE(r->tree_size, 150);
    EXPECT_LT(r->tree_size, 150 + 40);
    EXPECT_EQ(r->tree_size, (*out.results)[0]->tree_size);
  }
}

// Spec version 2: on a small city whose edges are close to every route, no
// mission's trajectory flies where a fall's impact window reaches past the map.
// The edit share: the single-start rule up to kMissionsPerEditShare missions
// with a solution (so RISK_RRT_STAR and small fleets are unchanged), then in
// proportion to them, fractions kept for Refine's credit to accumulate.
TEST(RefineEditsPerIterationTest, GrowsWithTheMissionsThatHaveASolution) {
  using rrt_star::kMissionsPerEditShare;
  using rrt_star::RefineEditsPerIteration;
  ASSERT_EQ(kMissionsPerEditShare, 4u);
  EXPECT_EQ(RefineEditsPerIteration(8.0, 1), 8.0);
  EXPECT_EQ(RefineEditsPerIteration(8.0, 4), 8.0);
  EXPECT_EQ(RefineEditsPerIteration(8.0, 5), 10.0);
  EXPECT_EQ(RefineEditsPerIteration(8.0, 32), 64.0);
  EXPECT_EQ(RefineEditsPerIteration(0.5, 32), 4.0);
  EXPECT_EQ(RefineEditsPerIteration(0.3, 6), 0.3 * 6 / 4);
  EXPECT_EQ(RefineEditsPerIteration(0.0, 256), 0.0);  // refinement off stays off
  for (size_t m = 1; m < 256; ++m) {
    EXPECT_LE(RefineEditsPerIteration(8.0, m), RefineEditsPerIteration(8.0, m + 1));
  }
}

TEST(SharedGoalTreeSmallMapTest, EveryImpactWindowStaysInsideTheMap) {
  DemoCityOptions city;
  city.size_m = 2000.0;
  city.res_m = 5.0;
  auto map = MakeDemoCity(city);
  ASSERT_TRUE(map.ok()) << map.status();
  auto made = RiskModel::Create(*map, ModelParams{});
  ASSERT_TRUE(made.ok()) << made.status();
  const std::shared_ptr<const RiskModel> model = *made;
  const double w = model->map().width_m();
  SharedTreeProblem problem;
  problem.model = model;
  const std::optional<Pose> goal = FindFlyablePose(*model, w / 2, w / 2, 0.0);
  ASSERT_TRUE(goal.has_value());
  problem.goal = *goal;
  const double spots[][3] = {{350, 350, 0.0},         {w - 350, 350, kPi / 2}, {350, w - 350, 0.0},
                             {w - 350, w - 350, kPi}, {w / 2, 300, kPi / 2},   {300, w / 2, 0.0}};
  for (const auto& s : spots) {
    const std::optional<Pose> start = FindFlyablePose(*model, s[0], s[1], s[2]);
    ASSERT_TRUE(start.has_value()) << s[0] << ", " << s[1];
    problem.missions.push_back(IterationMission(*start, 600));
  }
  FleetOutcome out = RunFleet(problem, 11);
  ASSERT_TRUE(out.results.ok()) << out.results.status();
  int64_t samples = 0;
  int solved = 0;
  for (const auto& r : *out.results) {
    ASSERT_TRUE(r.ok()) << r.status();
    if (!r->best.has_value()) continue;
    testing_planner::ExpectImpactWindowsInside(*model, r->best->waypoints, &samples);
    ++solved;
  }
  for (const auto& [mission, i] : out.improvements) {
    testing_planner::ExpectImpactWindowsInside(*model, i.waypoints, &samples);
  }
  EXPECT_GE(solved, 5);
  EXPECT_GT(samples, 1000);
}

}  // namespace
}  // namespace riskplan
