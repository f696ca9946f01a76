// The filter that makes every planner honour PlanOptions::limits
// (core/planners/flight_limits.h). MakePlanner's planners run each algorithm
// through PlanWithLimits.
#ifndef RISKPLAN_CORE_PLANNERS_LIMIT_FILTER_H_
#define RISKPLAN_CORE_PLANNERS_LIMIT_FILTER_H_

#include <functional>

#include "absl/status/statusor.h"
#include "core/planners/planner.h"
#include "core/risk/risk_evaluator.h"

namespace riskplan {

// Runs `algorithm` (an algorithm's Plan() with the problem and options bound)
// and filters what it reports with `options.limits`:
// - every trajectory it reports (and its final best) is evaluated once with
//   EvaluateTrajectory (`evaluator`, DirectRiskEvaluator when null): its risk,
//   length and flight time;
// - one that breaks a limit is never passed on nor returned;
// - one that meets them is passed on when it improves the objective: less
//   risk (MIN_RISK; the algorithm's own order), or less flight time
//   (MIN_TIME; equal times: less risk); a HARMONIC `replanned` one always
//   (and the front starts again);
// - with `pareto`, every one that meets them is offered to the front, which
//   every passed-on improvement and the result carry;
// - when the algorithm found trajectories but none met the limits, the result
//   has no trajectory, reason NO_SOLUTION and PlanResult::limits.note says
//   which limit could not be met and the best value found (the fastest
//   flight time for the endurance).
// With inactive limits (FlightLimits::Active() false) it only calls
// `algorithm`: nothing changes, improvements keep flight_time_s 0.
absl::StatusOr<PlanResult> PlanWithLimits(
    const std::function<absl::StatusOr<PlanResult>(const ImprovementCallback&)>& algorithm,
    const PlanningProblem& problem, const PlanOptions& options, RiskEvaluator* evaluator,
    const ImprovementCallback& on_improvement);

}  // namespace riskplan

#endif  // RISKPLAN_CORE_PLANNERS_LIMIT_FILTER_H_
