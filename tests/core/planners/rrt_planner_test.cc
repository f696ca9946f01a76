#include "core/planners/rrt_planner.h"

#include <chrono>
#include <cmath>
#include <thread>

#include "core/base/random.h"
#include "core/planners/obstacle_points.h"
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

constexpr PlannerAlgorithm kRrt = PlannerAlgorithm::kRrt;

double Distance2D(const Pose& a, const Pose& b) { return std::hypot(b.x - a.x, b.y - a.y); }

TEST(RrtPlannerTest, CorridorIsFlownStraightAndStopsAtTheFirstConnection) {
  const auto m = testing_maps::Corridor();
  const Outcome out = RunPlan(kRrt, m.model, m.start, m.goal, 20000, 1);
  ExpectSoundStream(*m.model, m.start, m.goal, out);
  EXPECT_EQ(out.result->reason, StopReason::kConverged);
  EXPECT_EQ(out.improvements.size(), 1u);
  EXPECT_LT(out.result->iterations, 20000);
  for (const Pose& q : TrajectorySamples(*m.model, out.result->best->waypoints)) {
    EXPECT_GT(q.y, 250.0);
    EXPECT_LT(q.y, 550.0);
  }
  EXPECT_LT(out.result->best->length_m, 1.1 * Distance2D(m.start, m.goal));
}

TEST(RrtPlannerTest, WallWithOneGapIsCrossedThroughTheGap) {
  const auto m = testing_maps::WallWithGap();
  for (uint64_t seed : {1, 2, 3}) {
    SCOPED_TRACE(seed);
    const Outcome out = RunPlan(kRrt, m.model, m.start, m.goal, 20000, seed);
    ExpectSoundStream(*m.model, m.start, m.goal, out);
    ExpectThroughTheGap(*m.model, out);
  }
}

TEST(RrtPlannerTest, GoalBehindAnObstacleIsReachedAroundIt) {
  const auto m = testing_maps::GoalBehindObstacle();
  const Outcome out = RunPlan(kRrt, m.model, m.start, m.goal, 20000, 4);
  ExpectSoundStream(*m.model, m.start, m.goal, out);
  ExpectAroundTheObstacle(*m.model, out);
  EXPECT_GT(out.result->best->length_m, 1.1 * Distance2D(m.start, m.goal));
}

// Growing on, the tree keeps connecting (on branches that mostly share the
// first one's trunk: RRT never rewires), streams only lower risks, and ends
// with the budget.
TEST(RrtPlannerTest, KeepGrowingRunsUntilTheBudgetEnds) {
  const auto model = testing_planner::DemoCityModel();
  const auto sc = testing_planner::DemoCityScenarios(*model)[4];
  const Outcome out = RunPlan(kRrt, model, sc.start, sc.goal, 8000, 5, {{"keep_growing", 1.0}});
  ExpectSoundStream(*model, sc.start, sc.goal, out);
  EXPECT_EQ(out.result->reason, StopReason::kBudgetExhausted);
  EXPECT_EQ(out.result->iterations, 8000);
  // Points closer than step_m are taken as they are: the tree outgrows the
  // number of step_m x step_m squares of the map (6400 on demo-city).
  EXPECT_GT(out.result->tree_size, 7000);
}

// A wall of request points with a gap, on a map with no obstacle of its own.
TEST(RrtPlannerTest, RequestObstaclePointsKeepTheirClearance) {
  const auto model = testing_maps::SyntheticModel("open", 200, 200, 10.0, nullptr);
  PlanOptions options;
  for (double y = 0.0; y <= 2000.0; y += 10.0) {
    if (y > 1300.0 && y < 1600.0) continue;
    options.obstacle_points.push_back({1000.0, y});
  }
  const Pose start{300.0, 600.0, kFlightZM, 0.0};
  const Pose goal{1700.0, 600.0, kFlightZM, 0.0};
  const double clearance = 30.0;
  const Outcome out =
      RunPlan(kRrt, model, start, goal, 20000, 1, {{"clearance_m", clearance}}, options);
  ExpectSoundStream(*model, start, goal, out);
  for (const Pose& q : TrajectorySamples(*model, out.result->best->waypoints)) {
    for (const Point2& p : options.obstacle_points) {
      ASSERT_GT(std::hypot(q.x - p.x, q.y - p.y), clearance) << q.x << " " << q.y;
    }
  }
}

TEST(RrtPlannerTest, RequestObstaclesAreCheckedAndRefusedWhereUnsupported) {
  const auto m = testing_maps::Corridor();
  PlanOptions near_start;
  near_start.obstacle_points = {{m.start.x + 5.0, m.start.y}};
  Outcome out = RunPlan(kRrt, m.model, m.start, m.goal, 100, 1, {}, near_start);
  ASSERT_FALSE(out.result.ok());
  EXPECT_NE(out.result.status().message().find("start pose"), std::string::npos)
      << out.result.status();
  EXPECT_NE(out.result.status().message().find("obstacle_points[0]"), std::string::npos);

  PlanOptions not_finite;
  not_finite.obstacle_points = {{std::nan(""), 1.0}};
  out = RunPlan(kRrt, m.model, m.start, m.goal, 100, 1, {}, not_finite);
  ASSERT_FALSE(out.result.ok());
  EXPECT_NE(out.result.status().message().find("finite"), std::string::npos);

  PlanOptions dynamic;
  dynamic.dynamic_obstacles = {{10, 0.0, 0.0, 10.0, 10.0}};
  out = RunPlan(kRrt, m.model, m.start, m.goal, 100, 1, {}, dynamic);
  ASSERT_FALSE(out.result.ok());
  EXPECT_NE(out.result.status().message().find("HARMONIC"), std::string::npos);

  PlanOptions points;
  points.obstacle_points = {{1.0, 1.0}};
  const absl::Status s = CheckRequestObstacles(PlannerAlgorithm::kRiskRrtStar, points);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(CheckRequestObstacles(PlannerAlgorithm::kGenetic, points).ok());
}

// Terrain at 200 m in a disc in the middle: at a flight altitude of 190 m it
// is an obstacle ("terrain above the flight altitude"), and the trajectory
// flies level around it.
TEST(RrtPlannerTest, FlightAltitudeMakesHigherTerrainAnObstacle) {
  const auto model = testing_maps::SyntheticModel(
      "hill", 200, 200, 10.0, nullptr, nullptr, [](double x, double y) {
        return std::hypot(x - 1000.0, y - 1000.0) < 300.0 ? 200.0f : 100.0f;
      });
  const Pose start{250.0, 1000.0, kFlightZM, 0.0};
  const Pose goal{1750.0, 1000.0, kFlightZM, 0.0};
  const Outcome out =
      RunPlan(kRrt, model, start, goal, 20000, 1, {{"flight_altitude_m", kFlightZM}});
  ExpectSoundStream(*model, start, goal, out);
  for (const Pose& w : out.result->best->waypoints) EXPECT_EQ(w.z, kFlightZM);
  for (const Pose& q : TrajectorySamples(*model, out.result->best->waypoints)) {
    EXPECT_GE(std::hypot(q.x - 1000.0, q.y - 1000.0), 300.0);
  }
}

TEST(RrtPlannerTest, SameSeedSameTrajectoryAndTreeIsRecorded) {
  const auto m = testing_maps::GoalBehindObstacle();
  PlanOptions options;
  options.record_tree = true;
  const Outcome a = RunPlan(kRrt, m.model, m.start, m.goal, 20000, 9, {}, options);
  const Outcome b = RunPlan(kRrt, m.model, m.start, m.goal, 20000, 9, {}, options);
  ASSERT_TRUE(a.result.ok() && b.result.ok());
  ExpectSameTrajectory(*a.result, *b.result);
  EXPECT_EQ(static_cast<int64_t>(a.result->tree.size()), a.result->tree_size - 1);
  const Outcome c = RunPlan(kRrt, m.model, m.start, m.goal, 20000, 10, {}, options);
  ASSERT_TRUE(c.result.ok() && c.result->best.has_value());
  EXPECT_NE(a.result->best->risk, c.result->best->risk);
}

TEST(RrtPlannerTest, DemoCityScenariosGiveSoundDeterministicTrajectories) {
  const auto model = testing_planner::DemoCityModel();
  const auto scenarios = testing_planner::DemoCityScenarios(*model);
  int solved = 0;
  for (size_t k = 0; k < scenarios.size(); k += 2) {
    const auto& sc = scenarios[k];
    SCOPED_TRACE(sc.name);
    const Outcome out = RunPlan(kRrt, model, sc.start, sc.goal, 20000, 3);
    ASSERT_TRUE(out.result.ok()) << out.result.status();
    if (!out.result->best.has_value()) continue;
    ++solved;
    ExpectSoundStream(*model, sc.start, sc.goal, out);
  }
  EXPECT_EQ(solved, static_cast<int>((scenarios.size() + 1) / 2));
  const auto& sc = scenarios[0];
  const Outcome a = RunPlan(kRrt, model, sc.start, sc.goal, 20000, 11, {{"keep_growing", 1.0}});
  const Outcome b = RunPlan(kRrt, model, sc.start, sc.goal, 20000, 11, {{"keep_growing", 1.0}});
  ASSERT_TRUE(a.result.ok() && b.result.ok());
  ExpectSameTrajectory(*a.result, *b.result);
  EXPECT_EQ(a.improvements.size(), b.improvements.size());
}

TEST(RrtPlannerTest, BadParametersAndBudgetsAreRefused) {
  const auto m = testing_maps::Corridor();
  Outcome out = RunPlan(kRrt, m.model, m.start, m.goal, 10, 1, {{"no_such", 1.0}});
  ASSERT_FALSE(out.result.ok());
  EXPECT_NE(out.result.status().message().find("unknown planner parameter 'no_such' for RRT"),
            std::string::npos)
      << out.result.status();
  out = RunPlan(kRrt, m.model, m.start, m.goal, 10, 1, {{"step_m", 0.0}});
  ASSERT_FALSE(out.result.ok());
  EXPECT_NE(out.result.status().message().find("step_m"), std::string::npos);
  out = RunPlan(kRrt, m.model, m.start, m.goal, 0, 1);
  ASSERT_FALSE(out.result.ok());
  EXPECT_NE(out.result.status().message().find("budget"), std::string::npos);
}

TEST(RrtPlannerTest, CancellationFromAnotherThreadStopsPromptly) {
  // The goal is walled in by request points, so the tree never connects.
  const auto model = testing_maps::SyntheticModel("open", 200, 200, 10.0, nullptr);
  const Pose start{300.0, 300.0, kFlightZM, 0.0};
  const Pose goal{1700.0, 1700.0, kFlightZM, 0.0};
  PlanOptions options;
  for (int k = 0; k < 16; ++k) {
    const double a = k * kTwoPi / 16;
    options.obstacle_points.push_back({goal.x + 40.0 * std::cos(a), goal.y + 40.0 * std::sin(a)});
  }
  options.budget.max_time_s = 600.0;
  // The largest tree allowed; cancelled long before it fills (it would end the
  // run as BUDGET_EXHAUSTED).
  options.params = {{"keep_growing", 1.0}, {"max_nodes", 300000}};
  auto planner = MakePlanner(kRrt);
  CancellationToken cancel;
  std::chrono::steady_clock::time_point cancelled;
  std::thread canceller([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    cancelled = std::chrono::steady_clock::now();
    cancel.Cancel();
  });
  auto result = (*planner)->Plan({model, start, goal}, options, cancel, nullptr);
  const auto returned = std::chrono::steady_clock::now();
  canceller.join();
  ASSERT_TRUE(result.ok()) << result.status();
  EXPECT_EQ(result->reason, StopReason::kCancelled);
  EXPECT_FALSE(result->best.has_value());
  EXPECT_LT(std::chrono::duration<double>(returned - cancelled).count(), 5.0);
}

TEST(ObstaclePointSetTest, IndexedClearanceTestIsTheBruteForceOne) {
  Rng rng(1);
  std::vector<Point2> points;
  for (int k = 0; k < 3000; ++k) points.push_back({rng.Uniform() * 1000.0, rng.Uniform() * 1000.0});
  const ObstaclePointSet set(points, 25.0);
  int clear = 0;
  for (int k = 0; k < 3000; ++k) {
    const Point2 a{rng.Uniform() * 1200.0 - 100.0, rng.Uniform() * 1200.0 - 100.0};
    const Point2 b{a.x + 60.0 * rng.Normal(), a.y + 60.0 * rng.Normal()};
    const double xi = 2.0 + 10.0 * rng.Uniform();
    const bool expected = set.SegmentClearBruteForce(a, b, xi);
    ASSERT_EQ(set.SegmentClear(a, b, xi), expected) << k;
    clear += expected;
  }
  EXPECT_GT(clear, 300);
  EXPECT_LT(clear, 2700);
}

// Coordinates and clearances far off the grid are clamped before any
// conversion to int (the request fuzz target found a clearance of 1e168 m
// converted out of int's range, undefined behaviour that UBSan reports), and
// the answers stay the brute force's.
TEST(ObstaclePointSetTest, FarCoordinatesAndHugeClearancesAreClampedOntoTheGrid) {
  const ObstaclePointSet set({{10.0, 10.0}, {90.0, 50.0}, {-1e20, 3e300}}, 5.0);
  const std::vector<std::pair<Point2, Point2>> segments = {
      {{0.0, 0.0}, {100.0, 100.0}},     {{-1e300, -1e300}, {1e300, 1e300}},
      {{-1.4e168, 5.0}, {5.0, 5.0}},    {{1e308, -1e308}, {-1e308, 1e308}},
      {{200.0, 200.0}, {300.0, 200.0}}, {{2e300, 0.0}, {2e300, 1.0}}};
  for (const double clearance : {0.5, 20.0, 1e168, 1e300}) {
    for (const auto& [a, b] : segments) {
      EXPECT_EQ(set.SegmentClear(a, b, clearance), set.SegmentClearBruteForce(a, b, clearance))
          << "(" << a.x << ", " << a.y << ") to (" << b.x << ", " << b.y << "), clearance "
          << clearance;
    }
    // (10, 10) and (90, 50) are 56.6 m and 40 m from (50, 50).
    EXPECT_EQ(set.PointWithin({50.0, 50.0}, clearance) >= 0, clearance >= 40.0) << clearance;
  }
  EXPECT_FALSE(set.SegmentClear({0.0, 0.0}, {100.0, 100.0}, 1e168));
  EXPECT_TRUE(set.SegmentClear({200.0, 200.0}, {300.0, 200.0}, 20.0));
}

TEST(ObstaclePointSetTest, MapPointsAreTheBordersOfBlockedRegions) {
  const auto m = testing_maps::GoalBehindObstacle();
  std::vector<uint8_t> flyable(m.model->map().layers().nofly.size());
  for (size_t k = 0; k < flyable.size(); ++k) flyable[k] = m.model->map().layers().nofly[k] == 0;
  const std::vector<Point2> points = MapObstaclePoints(m.model->map(), flyable);
  // The 60 x 60 cell square has 4 * 59 border cells.
  EXPECT_EQ(points.size(), 4u * 59u);
}

}  // namespace
}  // namespace riskplan
