// Domain values to API messages (the other direction is
// request_validation.h). Pure functions, thread-safe.
#ifndef RISKPLAN_SERVER_PROTO_CONVERT_H_
#define RISKPLAN_SERVER_PROTO_CONVERT_H_

#include <span>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/base/model_params.h"
#include "core/planners/planner.h"
#include "core/map/risk_map.h"
#include "core/flight/trajectory.h"
#include "core/planners/two_tier_feasibility.h"
#include "riskplan/v1/planner.pb.h"

namespace riskplan::server {

// Most poses in Trajectory.path; the display step grows for longer paths.
inline constexpr int kMaxDisplayPathPoses = 10000;
// Most tree edges in a final PlanUpdate.
inline constexpr size_t kMaxTreeEdges = 50000;

void PoseToProto(const Pose& pose, v1::Pose* out);

v1::ViolationKind ViolationKindToProto(ViolationKind kind);

// Fills risk, length, admissibility, first violation and pieces, and the
// samples when `include_samples`. Clears `out` first.
void EvaluationToProto(const TrajectoryEvaluation& evaluation, bool include_samples,
                       v1::EvaluateRiskResponse* out);

// The two-tier feasibility result; the collision fields only when infeasible.
void FeasibilityToProto(const FeasibilityResult& result, v1::TwoTierResult* out);

// The trajectory of an improvement: waypoints, risk, length, and the flown
// path sampled every `display_step_m` (Dubins-airplane pieces with `params`).
// Fails only if the waypoints do not make pieces (they always do for a
// planner's output).
absl::Status TrajectoryToProto(const PlanImprovement& improvement, const ModelParams& params,
                               double display_step_m, v1::Trajectory* out);

// The PlanUpdate of an improvement: its counts and trajectory (the caller
// sets `improvements` and `sequence`). INTERNAL, naming the improvement and
// what failed, when its waypoints do not make pieces (never for a planner's
// output).
absl::StatusOr<v1::PlanUpdate> ImprovementToProto(const PlanImprovement& improvement,
                                                  const ModelParams& params,
                                                  double display_step_m);

// The final PlanUpdate of a plan: final, `end_reason`, the counts, the best
// trajectory if there is one, and the first kMaxTreeEdges edges of the tree
// when `include_tree` (the caller sets `improvements` and `sequence`).
// INTERNAL, naming the best trajectory and what failed, when its waypoints do
// not make pieces (never for a planner's output).
absl::StatusOr<v1::PlanUpdate> FinalUpdateToProto(const PlanResult& result,
                                                  v1::EndReason end_reason,
                                                  const ModelParams& params, double display_step_m,
                                                  bool include_tree);

// Everything ListMaps says about `map`.
v1::MapInfo MapInfoFromMap(const RiskMap& map);

// One layer of `map` in blocks of factor x factor cells, factor =
// ceil(max(nx, ny) / max_side_cells). REQUIRES: max_side_cells >= 1, and
// `layer` one of POPULATION_DENSITY, SHELTER, TERRAIN, NO_FLY.
v1::GetMapLayerResponse DownsampleLayer(const RiskMap& map, v1::MapLayer layer, int max_side_cells);

// The end reason of a plan: the planner's stop reason, or SHUTDOWN when the
// server's shutdown cut it short (cancelled, or stopped before any solution).
v1::EndReason EndReasonToProto(StopReason reason, bool stopped_by_shutdown);

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_PROTO_CONVERT_H_
