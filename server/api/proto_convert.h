// Domain values to API messages (the other direction is
// request_validation.h). Pure functions, thread-safe.
#ifndef RISKPLAN_SERVER_API_PROTO_CONVERT_H_
#define RISKPLAN_SERVER_API_PROTO_CONVERT_H_

#include <optional>
#include <span>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/base/model_params.h"
#include "core/flight/trajectory.h"
#include "core/map/risk_map.h"
#include "core/planners/planner.h"
#include "core/planners/two_tier_feasibility.h"
#include "core/risk/risk_layer.h"
#include "geo/geo_frame.h"
#include "riskplan/v1/planner.pb.h"

namespace riskplan::server {

// Most poses in Trajectory.path; the display step grows for longer paths.
inline constexpr int kMaxDisplayPathPoses = 10000;
// Most tree edges in a final PlanUpdate.
inline constexpr size_t kMaxTreeEdges = 50000;

void PoseToProto(const Pose& pose, v1::Pose* out);
void GeoPoseToProto(const geo::GeoPose& pose, v1::GeoPose* out);

// The WGS84 form of each pose that `frame` covers (GeoFrame::Covers), in one
// batch; nullopt for the others (a pose of an EvaluateRisk trajectory may lie
// anywhere, and its answer still carries the local frame). Every entry is
// nullopt if PROJ fails (a pose at a pole).
std::vector<std::optional<geo::GeoPose>> ToWgs84Where(const geo::GeoFrame& frame,
                                                      std::span<const Pose> poses);

// How every response reports a trajectory's duration and its risk per
// flight hour (FlightTimeS, RiskPerFlightHour).
struct FlightHours {
  double flight_time_s = 0.0;
  double risk_per_flight_hour = 0.0;
};
// `flight_time_s` is the evaluation's (TrajectoryEvaluation::flight_time_s:
// length / v in still air, the sum of ds / ground speed in wind).
FlightHours FlightHoursOf(double risk, double flight_time_s);

// The flight time of `pieces` exactly as EvaluateTrajectory sums it: the
// length over the airspeed in still air; in wind each piece's midpoints'
// ds / gs(theta), in order (PieceRisk::FlightTimeS).
double PiecesFlightTimeS(std::span<const TrajectoryPiece> pieces, const ModelParams& params);

v1::ViolationKind ViolationKindToProto(ViolationKind kind);

// Fills risk, length, admissibility, first violation and pieces, the flight
// time and risk per flight hour (`params`' airspeed), and the samples when
// `include_samples`; with `frame` (a geo-referenced map, else null) the
// violation's and samples' WGS84 poses too. Clears `out` first.
void EvaluationToProto(const TrajectoryEvaluation& evaluation, const ModelParams& params,
                       bool include_samples, const geo::GeoFrame* frame,
                       v1::EvaluateRiskResponse* out);

// EvaluateRiskResponse.path: each path pose with its configuration risk
// (`risks[i]` of `path[i]`), the terrain under it, and with `frame` its WGS84
// pose. REQUIRES: risks.size() == path.size().
// Each pose's air heading and ground speed come from the wind of `params`.
void PathToProto(std::span<const PathPose> path, std::span<const ConfigurationRisk> risks,
                 const RiskMap& map, const ModelParams& params, const geo::GeoFrame* frame,
                 v1::EvaluateRiskResponse* out);

// The two-tier feasibility result; the collision fields only when
// infeasible (with `frame`, its position in WGS84 too).
void FeasibilityToProto(const FeasibilityResult& result, const geo::GeoFrame* frame,
                        v1::TwoTierResult* out);

// The trajectory of an improvement: waypoints, risk, length, flight time and
// risk per flight hour, and the flown path sampled every `display_step_m`
// (Dubins-airplane pieces with `params`); with `frame`, waypoints and path in
// WGS84 too. Fails only if the waypoints do not make pieces (they always do
// for a planner's output).
absl::Status TrajectoryToProto(const PlanImprovement& improvement, const ModelParams& params,
                               double display_step_m, const geo::GeoFrame* frame,
                               v1::Trajectory* out);

// The PlanUpdate of an improvement: its counts and trajectory (the caller
// sets `improvements` and `sequence`). INTERNAL, naming the improvement and
// what failed, when its waypoints do not make pieces (never for a planner's
// output).
absl::StatusOr<v1::PlanUpdate> ImprovementToProto(const PlanImprovement& improvement,
                                                  const ModelParams& params, double display_step_m,
                                                  const geo::GeoFrame* frame = nullptr);

// The final PlanUpdate of a plan: final, `end_reason`, the counts, the best
// trajectory if there is one, and the first kMaxTreeEdges edges of the tree
// when `include_tree` (the caller sets `improvements` and `sequence`), with
// `frame` also in WGS84.
// INTERNAL, naming the best trajectory and what failed, when its waypoints do
// not make pieces (never for a planner's output).
absl::StatusOr<v1::PlanUpdate> FinalUpdateToProto(const PlanResult& result,
                                                  v1::EndReason end_reason,
                                                  const ModelParams& params, double display_step_m,
                                                  bool include_tree,
                                                  const geo::GeoFrame* frame = nullptr);

// Everything ListMaps says about `map`; with `frame` (its WGS84 frame) also
// its geo-reference's origin and PROJ definition, its WGS84 bounds and the
// landing sites' positions.
v1::MapInfo MapInfoFromMap(const RiskMap& map, const geo::GeoFrame* frame = nullptr);

// GeoBounds of a local rectangle in `frame`; false (and `out` untouched)
// when PROJ cannot convert it.
bool BoundsToProto(const geo::GeoFrame& frame, double x_min, double y_min, double x_max,
                   double y_max, v1::GeoBounds* out);

// A computed risk layer (GetRiskLayerResponse), with its map window, and
// with `frame` its WGS84 bounds.
v1::GetRiskLayerResponse RiskLayerToProto(const RiskLayer& layer, const RiskMap& map,
                                          const RiskLayerOptions& options,
                                          const geo::GeoFrame* frame);

// One layer of `map` in blocks of factor x factor cells, factor =
// ceil(max(nx, ny) / max_side_cells). REQUIRES: max_side_cells >= 1, and
// `layer` one of POPULATION_DENSITY, SHELTER, TERRAIN, NO_FLY.
v1::GetMapLayerResponse DownsampleLayer(const RiskMap& map, v1::MapLayer layer, int max_side_cells);

// The end reason of a plan: the planner's stop reason, or SHUTDOWN when the
// server's shutdown cut it short (cancelled, or stopped before any solution).
v1::EndReason EndReasonToProto(StopReason reason, bool stopped_by_shutdown);

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_API_PROTO_CONVERT_H_
