// The filter that makes every planner honour PlanOptions::limits
// (core/planners/flight_limits.h). MakePlanner's planners run each algorithm
// through PlanWithLimits.
#ifndef RISKPLAN_CORE_PLANNERS_LIMIT_FILTER_H_
#define RISKPLAN_CORE_PLANNERS_LIMIT_FILTER_H_

#include <functional>
#include <vector>

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
//
// RISK_RRT_STAR with a limit on time or length, MIN_TIME or the front (and no
// guide_cell_m of the caller's) runs in two passes through the same filter.
// Without the limits in its tree (the front) its guide route alone tends to
// find the long safe route first and never a quick one (on demo-city's
// README demo every guided trajectory of the plain planner flies more than
// 780 s, while unguided ones sweep from 440 s to 700 s); with them (Run::
// SetLimits, an endurance) the guided probe meets the limit and the guided
// pass goes on:
// - MIN_RISK without the front: a guided probe with a quarter of the budget;
//   if one of its trajectories meets the limits, a guided pass with the other
//   three quarters (a new tree, same seed), else an unguided one;
// - MIN_TIME or the front: half unguided (the sweep from quick to safe), then
//   half guided (the safest routes).
// The improvements of the second pass count time and iterations from the
// start of the first.
using AlgorithmRun = std::function<absl::StatusOr<PlanResult>(const PlanOptions& options,
                                                              const ImprovementCallback& report)>;
absl::StatusOr<PlanResult> PlanWithLimits(PlannerAlgorithm algorithm, const AlgorithmRun& run,
                                          const PlanningProblem& problem,
                                          const PlanOptions& options, RiskEvaluator* evaluator,
                                          const ImprovementCallback& on_improvement);

// The passes PlanWithLimits runs: `options` itself, or for RISK_RRT_STAR
// under limits that trade risk for time the two above (for MIN_RISK the
// second is unguided until the probe chooses).
std::vector<PlanOptions> LimitPasses(PlannerAlgorithm algorithm, const PlanOptions& options);

}  // namespace riskplan

#endif  // RISKPLAN_CORE_PLANNERS_LIMIT_FILTER_H_
