// The emergency option of an in-flight alert: the landing site reachable by
// glide from a pose with the least altitude to spare, and the glide to it.
//
// It reads the same glide layer the risk model's safe altitude uses (spec
// section 6: ComputeGlideAltitude with the map's no-fly cells, here the
// session's zones among them, the model's glide ratio and clearance, and the
// wind of the glide), so "reachable" means exactly what admissibility means:
// pose.z >= glide(cell). The glide follows the layer down from the pose's
// cell, each step to the neighbour that minimises glide(n) + dist/G(c -> n)
// (the Dijkstra predecessor), which strictly lowers the glide altitude and so
// ends on a landing site.
#ifndef RISKPLAN_SERVER_FLIGHT_EMERGENCY_LANDING_H_
#define RISKPLAN_SERVER_FLIGHT_EMERGENCY_LANDING_H_

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/cancellation.h"
#include "core/base/geometry.h"
#include "core/risk/risk_model.h"

namespace riskplan::server {

struct EmergencyOption {
  std::string site;  // the landing site's name
  int site_i = 0;
  int site_j = 0;
  Pose site_pose;           // cell centre, at T + glide clearance
  std::vector<Pose> glide;  // from's cell centre ... the site's, each at the altitude left
  double glide_distance_m = 0.0;
  double altitude_margin_m = 0.0;  // from.z - glide(from's cell)
};

// The glide layer of `model` (RiskModel::glide_layer(): its map's own when
// the model uses it, else the model's), shared, never computed again.
absl::StatusOr<std::shared_ptr<const std::vector<double>>> GlideLayerOf(const RiskModel& model,
                                                                        const StopCondition& stop);

// The glide layer `model` would have with `nofly` (nx*ny) as its map's no-fly
// layer: its own repaired for the cells that differ (RepairGlideAltitude,
// GlideLayerWith's layer bit for bit). Cancelled at `stop`.
absl::StatusOr<std::shared_ptr<const std::vector<double>>> GlideLayerRepaired(
    const RiskModel& model, const std::vector<uint8_t>& nofly, const StopCondition& stop);

// The glide layer of `map`'s terrain, landing sites and `nofly` layer with
// `params`' glide ratio, clearance and wind (what RiskModel::Create computes
// for its own layer).
absl::StatusOr<std::shared_ptr<const std::vector<double>>> GlideLayerWith(
    const RiskMap& map, const std::vector<uint8_t>& nofly, const ModelParams& params,
    const StopCondition& stop);

// The option from `from` over `glide` (a layer of `map` with `params`), or
// nullopt when no landing site can be reached (from outside the map, or
// below its cell's glide altitude).
std::optional<EmergencyOption> FindEmergencyLanding(const RiskMap& map, const ModelParams& params,
                                                    const std::vector<double>& glide,
                                                    const Pose& from);

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_FLIGHT_EMERGENCY_LANDING_H_
