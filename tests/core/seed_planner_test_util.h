// Running a planner and checking what every planner must guarantee, for the
// tests of RRT, GENETIC and HARMONIC (and RunPlan for RISK_RRT_STAR's).
#ifndef RISKPLAN_TESTS_CORE_SEED_PLANNER_TEST_UTIL_H_
#define RISKPLAN_TESTS_CORE_SEED_PLANNER_TEST_UTIL_H_

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/planners/planner.h"
#include "gtest/gtest.h"
#include "tests/core/obstacle_test_maps.h"

namespace riskplan::testing_planner {

struct Outcome {
  absl::StatusOr<PlanResult> result;
  std::vector<PlanImprovement> improvements;
};

// Plans with an iteration budget (no time limit), so that runs repeat bit for
// bit.
inline Outcome RunPlan(PlannerAlgorithm algorithm, const std::shared_ptr<const RiskModel>& model,
                       const Pose& start, const Pose& goal, int64_t iterations, uint64_t seed,
                       std::map<std::string, double> params = {}, PlanOptions options = {}) {
  Outcome out;
  auto planner = MakePlanner(algorithm);
  EXPECT_TRUE(planner.ok());
  options.budget.max_time_s = 0.0;
  options.budget.max_iterations = iterations;
  options.seed = seed;
  options.params = std::move(params);
  CancellationToken cancel;
  out.result = (*planner)->Plan({model, start, goal}, options, cancel,
                                [&](const PlanImprovement& i) { out.improvements.push_back(i); });
  return out;
}

// What every streamed trajectory must satisfy: start and goal exactly the
// problem's, admissible under spec section 6, its risk and length exactly
// EvaluateTrajectory's, risks strictly decreasing (a replanned improvement
// starts again; not for GENETIC, ordered by fitness: `risk_ordered` false),
// and the result is the last improvement.
inline void ExpectSoundStream(const RiskModel& model, const Pose& start, const Pose& goal,
                              const Outcome& out, bool risk_ordered = true) {
  ASSERT_TRUE(out.result.ok()) << out.result.status();
  ASSERT_TRUE(out.result->best.has_value());
  ASSERT_FALSE(out.improvements.empty());
  for (size_t k = 0; k < out.improvements.size(); ++k) {
    SCOPED_TRACE(k);
    const PlanImprovement& i = out.improvements[k];
    ASSERT_GE(i.waypoints.size(), 2u);
    EXPECT_EQ(i.waypoints.front().x, start.x);
    EXPECT_EQ(i.waypoints.front().y, start.y);
    EXPECT_EQ(i.waypoints.front().z, start.z);
    EXPECT_EQ(i.waypoints.front().theta, start.theta);
    EXPECT_EQ(i.waypoints.back().x, goal.x);
    EXPECT_EQ(i.waypoints.back().y, goal.y);
    EXPECT_EQ(i.waypoints.back().z, goal.z);
    EXPECT_EQ(i.waypoints.back().theta, goal.theta);
    const TrajectoryEvaluation eval = testing_maps::Reevaluate(model, i.waypoints);
    EXPECT_TRUE(eval.admissible) << (eval.first_violation.has_value()
                                         ? eval.first_violation->ToString()
                                         : "");
    EXPECT_EQ(i.risk, eval.risk);
    EXPECT_EQ(i.length_m, eval.length_m);
    if (k > 0 && !i.replanned && risk_ordered) {
      EXPECT_LT(i.risk, out.improvements[k - 1].risk);
    }
    if (k > 0) {
      EXPECT_GE(i.iterations, out.improvements[k - 1].iterations);
    }
  }
  EXPECT_EQ(out.result->best->risk, out.improvements.back().risk);
  EXPECT_EQ(out.result->best->waypoints.size(), out.improvements.back().waypoints.size());
}

// On testing_maps::WallWithGap: the best trajectory crosses the wall, and
// only through its gap.
inline void ExpectThroughTheGap(const RiskModel& model, const Outcome& out) {
  int in_wall = 0;
  for (const Pose& q : testing_maps::TrajectorySamples(model, out.result->best->waypoints)) {
    if (q.x > 950.0 && q.x < 1050.0) {
      ++in_wall;
      EXPECT_GT(q.y, testing_maps::kGapLowM);
      EXPECT_LT(q.y, testing_maps::kGapHighM);
    }
  }
  EXPECT_GT(in_wall, 0);
}

// On testing_maps::GoalBehindObstacle: the best trajectory goes around the
// obstacle, at least 300 m off the straight line where it stands.
inline void ExpectAroundTheObstacle(const RiskModel& model, const Outcome& out) {
  double widest = 0.0;
  for (const Pose& q : testing_maps::TrajectorySamples(model, out.result->best->waypoints)) {
    if (q.x > 700.0 && q.x < 1300.0) widest = std::max(widest, std::abs(q.y - 1000.0));
  }
  EXPECT_GE(widest, 300.0);
}

// Bit-for-bit equality of two results' trajectories.
inline void ExpectSameTrajectory(const PlanResult& a, const PlanResult& b) {
  ASSERT_TRUE(a.best.has_value());
  ASSERT_TRUE(b.best.has_value());
  EXPECT_EQ(a.best->risk, b.best->risk);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.tree_size, b.tree_size);
  ASSERT_EQ(a.best->waypoints.size(), b.best->waypoints.size());
  for (size_t k = 0; k < a.best->waypoints.size(); ++k) {
    const Pose& p = a.best->waypoints[k];
    const Pose& q = b.best->waypoints[k];
    EXPECT_EQ(p.x, q.x);
    EXPECT_EQ(p.y, q.y);
    EXPECT_EQ(p.z, q.z);
    EXPECT_EQ(p.theta, q.theta);
  }
}

}  // namespace riskplan::testing_planner

#endif  // RISKPLAN_TESTS_CORE_SEED_PLANNER_TEST_UTIL_H_
