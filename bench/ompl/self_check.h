// Checks that the OMPL adapter poses exactly riskplan's problem, before any
// figure is measured with it:
// - RiskObjective::motionCost of an admissible edge equals the piece risk
//   EvaluateTrajectory computes for the same two waypoints, bit for bit, and
//   a path's summed cost equals EvaluateTrajectory's total;
// - RiskMotionValidator accepts exactly the edges EvaluateTrajectory finds
//   admissible;
// - DubinsAirplaneSpace round-trips poses and interpolates along the
//   manoeuvre;
// - GridNearestNeighbors answers nearestK and nearestR exactly as OMPL's
//   NearestNeighborsLinear does.
#ifndef RISKPLAN_BENCH_OMPL_SELF_CHECK_H_
#define RISKPLAN_BENCH_OMPL_SELF_CHECK_H_

#include <memory>

#include "core/risk/risk_model.h"

namespace riskplan::bench {

// Runs the checks on `edges` random edges of `model`'s map (seeded, so the
// same every time) and prints one line per check. Returns false when any
// exactness check fails.
bool RunSelfCheck(std::shared_ptr<const RiskModel> model, int edges);

}  // namespace riskplan::bench

#endif  // RISKPLAN_BENCH_OMPL_SELF_CHECK_H_
