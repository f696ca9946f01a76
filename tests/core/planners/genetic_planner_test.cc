#include "core/planners/genetic_planner.h"

#include <cmath>

#include "core/planners/planner_support.h"
#include "gtest/gtest.h"
#include "tests/core/obstacle_test_maps.h"
#include "tests/core/planner_test_util.h"
#include "tests/core/seed_planner_test_util.h"

namespace riskplan {
namespace {

using testing_maps::kFlightZM;
using testing_maps::TrajectorySamples;
using testing_planner::ExpectAroundTheObstacle;
using testing_planner::ExpectSameTrajectory;
using testing_planner::ExpectSoundStream;
using testing_planner::ExpectThroughTheGap;
using testing_planner::Outcome;
using testing_planner::RunPlan;

constexpr PlannerAlgorithm kGenetic = PlannerAlgorithm::kGenetic;
constexpr int64_t kGenerations = 150;

TEST(GeneticPlannerTest, CorridorIsFlownAlongIt) {
  const auto m = testing_maps::Corridor();
  const Outcome out = RunPlan(kGenetic, m.model, m.start, m.goal, kGenerations, 1);
  ExpectSoundStream(*m.model, m.start, m.goal, out, /*risk_ordered=*/false);
  EXPECT_EQ(out.result->reason, StopReason::kBudgetExhausted);
  EXPECT_EQ(out.result->iterations, kGenerations);
  EXPECT_LT(out.result->best->length_m, 1.2 * (m.goal.x - m.start.x));
}

TEST(GeneticPlannerTest, WallWithOneGapIsCrossedThroughTheGap) {
  const auto m = testing_maps::WallWithGap();
  for (uint64_t seed : {1, 2}) {
    SCOPED_TRACE(seed);
    const Outcome out = RunPlan(kGenetic, m.model, m.start, m.goal, kGenerations, seed);
    ExpectSoundStream(*m.model, m.start, m.goal, out, /*risk_ordered=*/false);
    ExpectThroughTheGap(*m.model, out);
  }
}

TEST(GeneticPlannerTest, GoalBehindAnObstacleIsReachedAroundIt) {
  const auto m = testing_maps::GoalBehindObstacle();
  const Outcome out = RunPlan(kGenetic, m.model, m.start, m.goal, kGenerations, 3);
  ExpectSoundStream(*m.model, m.start, m.goal, out, /*risk_ordered=*/false);
  ExpectAroundTheObstacle(*m.model, out);
}

// A dense block on the straight line and sparse ground around it: with its
// risk weight the GA flies around the block, without it nearly straight.
TEST(GeneticPlannerTest, RiskWeightTradesLengthForRisk) {
  const auto model =
      testing_maps::SyntheticModel("dense-block", 200, 200, 10.0, nullptr, [](double x, double y) {
        return (x > 700.0 && x < 1300.0 && y > 600.0 && y < 1400.0) ? 0.05f : 1e-5f;
      });
  const Pose start{250.0, 1000.0, kFlightZM, 0.0};
  const Pose goal{1750.0, 1000.0, kFlightZM, 0.0};
  const double direct = testing_maps::Reevaluate(*model, {start, goal}).risk;
  const Outcome risky = RunPlan(kGenetic, model, start, goal, kGenerations, 1);
  ExpectSoundStream(*model, start, goal, risky, /*risk_ordered=*/false);
  const Outcome short_only =
      RunPlan(kGenetic, model, start, goal, kGenerations, 1, {{"risk_weight", 0.0}});
  ExpectSoundStream(*model, start, goal, short_only, /*risk_ordered=*/false);
  EXPECT_LT(risky.result->best->risk, 0.3 * direct);
  EXPECT_LT(risky.result->best->risk, 0.5 * short_only.result->best->risk);
  EXPECT_LT(short_only.result->best->length_m, risky.result->best->length_m);
  EXPECT_LT(short_only.result->best->length_m, 1.1 * (goal.x - start.x));
}

TEST(GeneticPlannerTest, ElevationModes) {
  const auto m = testing_maps::WallWithGap();
  const Outcome fixed = RunPlan(kGenetic, m.model, m.start, m.goal, 80, 1,
                                {{"elevation_mode", 1.0}, {"fixed_altitude_m", 220.0}});
  ExpectSoundStream(*m.model, m.start, m.goal, fixed, /*risk_ordered=*/false);
  const auto& w = fixed.result->best->waypoints;
  ASSERT_EQ(w.size(), 6u);
  for (size_t k = 1; k + 1 < w.size(); ++k) EXPECT_EQ(w[k].z, 220.0);
  const Outcome free = RunPlan(kGenetic, m.model, m.start, m.goal, 80, 1);
  ExpectSoundStream(*m.model, m.start, m.goal, free, /*risk_ordered=*/false);
  int off_fixed = 0;
  for (const Pose& p : free.result->best->waypoints) off_fixed += p.z != 220.0;
  EXPECT_GT(off_fixed, 0);
  // Fewer transitional waypoints.
  const Outcome two = RunPlan(kGenetic, m.model, m.start, m.goal, 80, 1, {{"waypoints", 2.0}});
  ExpectSoundStream(*m.model, m.start, m.goal, two, /*risk_ordered=*/false);
  EXPECT_EQ(two.result->best->waypoints.size(), 4u);
}

TEST(GeneticPlannerTest, RequestObstaclePointsKeepTheirClearance) {
  const auto model = testing_maps::SyntheticModel("open", 200, 200, 10.0, nullptr);
  PlanOptions options;
  for (double y = 0.0; y <= 2000.0; y += 10.0) {
    if (y > 1300.0 && y < 1600.0) continue;
    options.obstacle_points.push_back({1000.0, y});
  }
  const Pose start{300.0, 600.0, kFlightZM, 0.0};
  const Pose goal{1700.0, 600.0, kFlightZM, 0.0};
  const Outcome out = RunPlan(kGenetic, model, start, goal, kGenerations, 1, {}, options);
  ExpectSoundStream(*model, start, goal, out, /*risk_ordered=*/false);
  for (const Pose& q : TrajectorySamples(*model, out.result->best->waypoints)) {
    for (const Point2& p : options.obstacle_points) {
      ASSERT_GT(std::hypot(q.x - p.x, q.y - p.y), 20.0);
    }
  }
}

TEST(GeneticPlannerTest, DemoCityScenariosGiveSoundDeterministicTrajectories) {
  const auto model = testing_planner::DemoCityModel();
  const auto scenarios = testing_planner::DemoCityScenarios(*model);
  int better_than_direct = 0;
  int compared = 0;
  for (size_t k : {0, 4, 10, 16}) {
    const auto& sc = scenarios[k];
    SCOPED_TRACE(sc.name);
    const Outcome out = RunPlan(kGenetic, model, sc.start, sc.goal, 100, 1);
    ExpectSoundStream(*model, sc.start, sc.goal, out, /*risk_ordered=*/false);
    const TrajectoryEvaluation direct = testing_maps::Reevaluate(*model, {sc.start, sc.goal});
    if (direct.admissible) {
      ++compared;
      better_than_direct += out.result->best->risk < direct.risk;
    }
  }
  EXPECT_EQ(better_than_direct, compared);
  const auto& sc = scenarios[0];
  const Outcome a = RunPlan(kGenetic, model, sc.start, sc.goal, 40, 7);
  const Outcome b = RunPlan(kGenetic, model, sc.start, sc.goal, 40, 7);
  ASSERT_TRUE(a.result.ok() && b.result.ok());
  ExpectSameTrajectory(*a.result, *b.result);
  EXPECT_EQ(a.improvements.size(), b.improvements.size());
  const Outcome c = RunPlan(kGenetic, model, sc.start, sc.goal, 40, 8);
  ASSERT_TRUE(c.result.ok() && c.result->best.has_value());
  EXPECT_NE(a.result->best->risk, c.result->best->risk);
}

TEST(GeneticPlannerTest, BadParametersAreRefused) {
  const auto m = testing_maps::Corridor();
  Outcome out = RunPlan(kGenetic, m.model, m.start, m.goal, 10, 1, {{"waypoints", 17.0}});
  ASSERT_FALSE(out.result.ok());
  EXPECT_NE(out.result.status().message().find("waypoints"), std::string::npos);
  out = RunPlan(kGenetic, m.model, m.start, m.goal, 10, 1, {{"risk_weight", -0.1}});
  ASSERT_FALSE(out.result.ok());
  PlanOptions dynamic;
  dynamic.dynamic_obstacles = {{1, 0.0, 0.0, 10.0, 10.0}};
  out = RunPlan(kGenetic, m.model, m.start, m.goal, 10, 1, {}, dynamic);
  ASSERT_FALSE(out.result.ok());
}

TEST(GeneticPlannerTest, CancellationInTheCallbackStopsAfterTheGeneration) {
  const auto m = testing_maps::WallWithGap();
  auto planner = MakePlanner(kGenetic);
  PlanOptions options;
  options.budget.max_time_s = 600.0;
  CancellationToken cancel;
  int64_t cancelled_at = -1;
  auto result =
      (*planner)->Plan({m.model, m.start, m.goal}, options, cancel, [&](const PlanImprovement& i) {
        cancelled_at = i.iterations;
        cancel.Cancel();
      });
  ASSERT_TRUE(result.ok());
  EXPECT_EQ(result->reason, StopReason::kCancelled);
  EXPECT_EQ(result->iterations, cancelled_at);
  EXPECT_TRUE(result->best.has_value());
}

}  // namespace
}  // namespace riskplan
