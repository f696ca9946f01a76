// GetRiskLayer at the RPC edge: a request checked field by field and its
// work counted before anything is queued (docs/api.md, "GetRiskLayer").
#ifndef RISKPLAN_SERVER_API_RISK_LAYER_REQUEST_H_
#define RISKPLAN_SERVER_API_RISK_LAYER_REQUEST_H_

#include <cstdint>
#include <memory>

#include "absl/status/statusor.h"
#include "core/base/model_params.h"
#include "core/map/risk_map.h"
#include "core/risk/risk_layer.h"
#include "geo/geo_frame.h"
#include "riskplan/v1/planner.pb.h"
#include "server/models/map_registry.h"
#include "server/api/request_validation.h"

namespace riskplan::server {

// Most cells of a GetRiskLayer response (8 bytes each: 32 MiB, inside the
// 64 MiB a client accepts).
inline constexpr int64_t kMaxRiskLayerCells = int64_t{1} << 22;

// A validated GetRiskLayerRequest: the map, its frame, the model
// parameters, and the layer options (window, stride, height, heading; one
// thread) whose work LayerCells has counted within the limits.
struct RiskLayerSpec {
  std::shared_ptr<const RiskMap> map;
  std::shared_ptr<const geo::GeoFrame> frame;
  ModelParams params;
  RiskLayerOptions options;
  int64_t cells = 0;
  int64_t evaluations = 0;
  // The wind of params, as GetRiskLayerResponse echoes it.
  v1::WindReport wind;
};

// Checks every field of a GetRiskLayerRequest and counts the layer's cells
// and configuration risks before anything is computed: more than
// kMaxRiskLayerCells cells or limits.max_risk_layer_evaluations risks is
// INVALID_ARGUMENT naming both numbers and the limit. The region (local or
// WGS84) becomes the window of map cells it overlaps, clipped to the map.
absl::StatusOr<RiskLayerSpec> ValidateRiskLayerRequest(const v1::GetRiskLayerRequest& request,
                                                       const MapRegistry& registry,
                                                       const RequestLimits& limits);

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_API_RISK_LAYER_REQUEST_H_
