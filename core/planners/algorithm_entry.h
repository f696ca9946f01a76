// What each planning algorithm's file offers MakePlanner and PlannerParams:
// its parameter table and its Plan(). One Planner class (in planner.cc) holds
// the caller's evaluator and serves all four algorithms through these entries,
// so that no algorithm repeats the shell of a planner class; each algorithm's
// header declares its entry. The entries are constinit, so PlannerParams works
// during static initialisation too.
#ifndef RISKPLAN_CORE_PLANNERS_ALGORITHM_ENTRY_H_
#define RISKPLAN_CORE_PLANNERS_ALGORITHM_ENTRY_H_

#include <vector>

#include "absl/status/statusor.h"
#include "core/base/cancellation.h"
#include "core/planners/planner.h"
#include "core/risk/risk_evaluator.h"

namespace riskplan {

struct AlgorithmEntry {
  // Names, defaults and ranges of the algorithm's parameters (PlannerParams).
  const std::vector<PlannerParamInfo>& (*param_info)();
  // Planner::Plan() of the algorithm, with the evaluator given to MakePlanner
  // (null: the algorithm's own).
  absl::StatusOr<PlanResult> (*plan)(RiskEvaluator* evaluator, const PlanningProblem& problem,
                                     const PlanOptions& options, const CancellationToken& cancel,
                                     const ImprovementCallback& on_improvement);
};

}  // namespace riskplan

#endif  // RISKPLAN_CORE_PLANNERS_ALGORITHM_ENTRY_H_
