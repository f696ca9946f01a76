#include "core/planners/path_realizer.h"

#include <cmath>
#include <vector>

#include "gtest/gtest.h"
#include "tests/core/obstacle_test_maps.h"

namespace riskplan {
namespace {

using testing_maps::kFlightZM;

TEST(PathRealizerTest, BisectorHeading) {
  EXPECT_DOUBLE_EQ(BisectorHeading({0, 0}, {10, 0}, {20, 0}), 0.0);
  EXPECT_DOUBLE_EQ(BisectorHeading({0, 0}, {10, 0}, {10, 10}), kPi / 4);
  EXPECT_DOUBLE_EQ(BisectorHeading({0, 0}, {10, 0}, {10, -10}), kTwoPi - kPi / 4);
  // Across the +-pi cut: west then south-west-ish.
  EXPECT_NEAR(BisectorHeading({10, 0}, {0, 0}, {-10, -10}), kPi + kPi / 8, 1e-12);
  EXPECT_DOUBLE_EQ(BisectorHeading({0, 0}, {0, 0}, {0, 10}), kPi / 2);
  EXPECT_DOUBLE_EQ(BisectorHeading({0, 0}, {0, 0}, {0, 0}), 0.0);
}

TEST(PathRealizerTest, SegmentTouchesArea) {
  const ClosedArea area{10.0, 10.0, 20.0, 20.0};
  EXPECT_TRUE(SegmentTouchesArea({0, 15}, {30, 15}, area));
  EXPECT_TRUE(SegmentTouchesArea({12, 12}, {13, 13}, area));  // inside
  EXPECT_FALSE(SegmentTouchesArea({0, 10}, {5, 10}, area));
  EXPECT_TRUE(SegmentTouchesArea({0, 0}, {10, 10}, area));  // the corner
  EXPECT_FALSE(SegmentTouchesArea({0, 21}, {30, 21}, area));
  EXPECT_FALSE(SegmentTouchesArea({0, 0}, {30, 5}, area));
}

TEST(PathRealizerTest, StraightFreePathIsOneManoeuvre) {
  const auto m = testing_maps::Corridor();
  const TrajectoryChecker checker(*m.model, nullptr, 0.0);
  const PathRealizer realizer(checker, {});
  const std::vector<Point2> path = {{m.start.x, m.start.y}, {1000.0, 420.0}, {m.goal.x, m.goal.y}};
  auto waypoints = realizer.Realize(m.start, m.goal, path);
  ASSERT_TRUE(waypoints.has_value());
  EXPECT_EQ(waypoints->size(), 2u);
}

// Around the square of GoalBehindObstacle along its south side: a path with
// two corners becomes waypoints near them, within the deviation limit, and
// every manoeuvre passes the exact check.
TEST(PathRealizerTest, CorneredPathFollowsThePathWithinTheLimit) {
  const auto m = testing_maps::GoalBehindObstacle();
  const TrajectoryChecker checker(*m.model, nullptr, 0.0);
  const std::vector<Point2> path = {
      {m.start.x, m.start.y}, {600.0, 550.0}, {1400.0, 550.0}, {m.goal.x, m.goal.y}};
  for (double limit : {0.0, 60.0}) {
    SCOPED_TRACE(limit);
    RealizerOptions options;
    options.max_deviation_m = limit;
    const PathRealizer realizer(checker, options);
    auto waypoints = realizer.Realize(m.start, m.goal, path);
    ASSERT_TRUE(waypoints.has_value());
    EXPECT_GE(waypoints->size(), 3u);
    EXPECT_EQ(checker.Violations(*waypoints, /*first_only=*/false), 0);
    const TrajectoryEvaluation eval = testing_maps::Reevaluate(*m.model, *waypoints);
    EXPECT_TRUE(eval.admissible);
    for (size_t k = 1; k + 1 < waypoints->size(); ++k) {
      EXPECT_GE((*waypoints)[k].z, 130.0 + 3.0);  // inside the band's margin
      EXPECT_LE((*waypoints)[k].z, 250.0 - 3.0);
    }
  }
}

TEST(PathRealizerTest, PathThroughANoFlyCellIsRefused) {
  const auto m = testing_maps::GoalBehindObstacle();
  const TrajectoryChecker checker(*m.model, nullptr, 0.0);
  const PathRealizer realizer(checker, {});
  const std::vector<Point2> path = {{m.start.x, m.start.y}, {m.goal.x, m.goal.y}};
  EXPECT_FALSE(realizer.Realize(m.start, m.goal, path).has_value());
}

TEST(PathRealizerTest, CheckerCountsSamplesAndChords) {
  const auto model = testing_maps::SyntheticModel("open", 100, 100, 10.0, nullptr);
  const ObstaclePointSet points({{500.0, 505.0}}, 20.0);
  const TrajectoryChecker checker(*model, &points, 20.0, {{700.0, 400.0, 720.0, 600.0}});
  // Clear of the edges, where a fall's impact window would reach past the map.
  const Pose a{250.0, 500.0, kFlightZM, 0.0};
  const Pose b{850.0, 500.0, kFlightZM, 0.0};
  const TrajectoryPiece piece = TrajectoryPiece::Manoeuvre(a, b, 50.0, 0.15);
  // 120 samples 5 m apart: chords within 20 m of the point (about 8) and
  // crossing the 20 m wide area (about 5).
  const int violations = checker.Violations(piece, /*first_only=*/false);
  EXPECT_GE(violations, 10);
  EXPECT_LE(violations, 16);
  EXPECT_EQ(checker.Violations(piece, /*first_only=*/true), 1);
  const TrajectoryChecker plain(*model, nullptr, 0.0);
  EXPECT_EQ(plain.Violations(piece, /*first_only=*/false), 0);
  const Pose high{850.0, 500.0, 400.0, 0.0};
  EXPECT_GT(plain.Violations(std::vector<Pose>{a, high}, /*first_only=*/false), 0);
}

}  // namespace
}  // namespace riskplan
