// The evaluator a plan (a PlanTrajectory call, a fleet's mission, a Fly
// session's replan) computes its risks with.
#ifndef RISKPLAN_SERVER_PLAN_PLAN_EVALUATOR_H_
#define RISKPLAN_SERVER_PLAN_PLAN_EVALUATOR_H_

#include <memory>

#include "accel/risk_engine.h"
#include "core/base/cancellation.h"
#include "core/planners/planner.h"
#include "core/risk/risk_evaluator.h"

namespace riskplan::server {

// The evaluator one plan computes its risks with. With an engine, the
// engine's (its batches stop waiting for boards once `stop` is reached).
// Without one, accel's exact CPU kernel on the planning thread: the same
// risks bit for bit as the planner's own one-window loop, so the same plans,
// in less time (docs/benchmarks.md, "Tree nodes per second"); except that a
// request asking for the planner's exact risk cache (risk_cache_log2 > 0)
// gets it (null: the planner evaluates with its own).
std::unique_ptr<RiskEvaluator> NewPlanEvaluator(accel::RiskEngine* engine,
                                                const PlanOptions& options, StopCondition stop);

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_PLAN_PLAN_EVALUATOR_H_
