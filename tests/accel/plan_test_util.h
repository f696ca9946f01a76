// Planning problems on the small demo-city and helpers to compare plans made
// through different risk paths (CPU, a shim's model, the RTL).
#ifndef RISKPLAN_TESTS_ACCEL_PLAN_TEST_UTIL_H_
#define RISKPLAN_TESTS_ACCEL_PLAN_TEST_UTIL_H_

#include <cmath>
#include <memory>
#include <vector>

#include "accel_test_util.h"
#include "bench/scenarios.h"
#include "core/planners/planner.h"

namespace riskplan::accel::testing {

struct Endpoints {
  double x0, y0, x1, y1;
};

inline std::vector<PlanningProblem> Problems() {
  const std::shared_ptr<const RiskModel> model = SmallCity();
  const Endpoints raw[] = {{300, 300, 2700, 2700},  {2700, 300, 300, 2700}, {300, 1500, 2700, 1500},
                           {1500, 300, 1500, 2700}, {500, 2500, 2500, 600}, {800, 800, 2200, 1200},
                           {2600, 2000, 400, 900},  {1200, 2700, 1800, 300}};
  std::vector<PlanningProblem> problems;
  for (const Endpoints& e : raw) {
    const double theta = std::atan2(e.y1 - e.y0, e.x1 - e.x0);
    auto start = bench::FindFlyablePose(*model, e.x0, e.y0, theta < 0 ? theta + kTwoPi : theta);
    auto goal = bench::FindFlyablePose(*model, e.x1, e.y1, theta < 0 ? theta + kTwoPi : theta);
    if (start && goal) problems.push_back(PlanningProblem{model, *start, *goal});
  }
  return problems;
}

// A Risk-based RRT* plan of `iterations` samples, seed 5, on `evaluator`'s
// risks (the CPU's when null).
inline absl::StatusOr<PlanResult> PlanWith(RiskEvaluator* evaluator, const PlanningProblem& problem,
                                           int iterations = 250) {
  auto planner = MakePlanner(PlannerAlgorithm::kRiskRrtStar, evaluator);
  if (!planner.ok()) return planner.status();
  PlanOptions options;
  options.budget.max_time_s = 0.0;
  options.budget.max_iterations = iterations;
  options.seed = 5;
  CancellationToken cancel;
  return (*planner)->Plan(problem, options, cancel, nullptr);
}

inline bool SameWaypoints(const PlanResult& a, const PlanResult& b) {
  if (a.best.has_value() != b.best.has_value()) return false;
  if (!a.best) return true;
  if (a.best->waypoints.size() != b.best->waypoints.size()) return false;
  for (size_t w = 0; w < a.best->waypoints.size(); ++w) {
    const Pose& p = a.best->waypoints[w];
    const Pose& q = b.best->waypoints[w];
    if (p.x != q.x || p.y != q.y || p.z != q.z || p.theta != q.theta) return false;
  }
  return true;
}

}  // namespace riskplan::accel::testing

#endif  // RISKPLAN_TESTS_ACCEL_PLAN_TEST_UTIL_H_
