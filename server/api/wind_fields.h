// The wind of a request (docs/api.md, "Wind"): a request's `wind` (local:
// speed and direction from grid north, or the air's vector) or `wind_wgs84`
// (direction from true north, on a geo-referenced map) into the model
// parameters, checked with errors that name the request's fields; and the
// WindReport every answer echoes.
#ifndef RISKPLAN_SERVER_API_WIND_FIELDS_H_
#define RISKPLAN_SERVER_API_WIND_FIELDS_H_

#include <string_view>

#include "absl/status/status.h"
#include "core/base/model_params.h"
#include "core/map/risk_map.h"
#include "geo/geo_frame.h"
#include "riskplan/v1/planner.pb.h"
#include "server/models/map_registry.h"

namespace riskplan::server {

// Where a request keeps its wind (PlanRequest, EvaluateRiskRequest and
// GetRiskLayerRequest share the two fields `wind` and `wind_wgs84`).
struct RequestWind {
  const v1::Wind* wind = nullptr;         // set when the request has `wind`
  const v1::GeoWind* wind_wgs84 = nullptr;  // set when it has `wind_wgs84`
  const v1::ModelParameters* model_params = nullptr;
};

template <typename Request>
RequestWind RequestWindOf(const Request& request) {
  RequestWind out;
  if (request.has_wind()) out.wind = &request.wind();
  if (request.has_wind_wgs84()) out.wind_wgs84 = &request.wind_wgs84();
  out.model_params = &request.model_params();
  return out;
}

// Sets params->wind_speed_mps and wind_from_deg from the request's wind, if
// any (params holds model_params already, validated). INVALID_ARGUMENT, naming
// the field: a wind given both in `wind` (or `wind_wgs84`) and in
// model_params.wind_speed_mps / wind_from_deg; a speed or direction that is
// not finite ("wind.from.from_deg has value nan; it must be finite"); a
// negative speed; a speed above half the airspeed ("wind.from.speed_mps has
// value 10; it must be at most 0.5 * model_params.airspeed_mps = 9 m/s");
// `wind_wgs84` on a map without geo-reference. A finite direction is taken
// modulo 360 (the model does it).
absl::Status ApplyRequestWind(const RequestWind& request, const MapRegistry& registry,
                              const RiskMap& map, ModelParams* params);

// The grid convergence at the centre of `map`, degrees (0 without a frame, or
// if PROJ cannot give it): a direction from true north ψ is ψ − γ from grid
// north.
double MapConvergenceDeg(const RiskMap& map, const geo::GeoFrame* frame);

// The wind of `params` as answers echo it; from_true_deg set when `frame`.
v1::WindReport WindReportOf(const ModelParams& params, const RiskMap& map,
                            const geo::GeoFrame* frame);

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_API_WIND_FIELDS_H_
