// What the two fuzz targets that run the service share (request_fuzz.cc and
// web_gateway_fuzz.cc): small limits, so that an input can reach every one
// of them, and the maps it serves: a 1 km demo-city at 10 m cells, as
// "demo-city" without a geo-reference and as "geo-city" with one, so that
// the WGS84 fields of requests and answers are converted too.
#ifndef RISKPLAN_FUZZ_FUZZ_SERVER_H_
#define RISKPLAN_FUZZ_FUZZ_SERVER_H_

#include <cstddef>
#include <memory>
#include <utility>

#include "absl/status/statusor.h"
#include "core/map/demo_city.h"
#include "core/map/risk_map.h"
#include "fuzz/fuzz_support.h"
#include "server/models/map_registry.h"
#include "server/api/request_validation.h"

namespace riskplan::fuzz {

// Limits a plan of tens of milliseconds and a few thousand samples can reach.
inline server::RequestLimits FuzzLimits() {
  server::RequestLimits limits;
  limits.max_plan_time_ms = 40;
  limits.default_plan_time_ms = 10;
  limits.max_iterations = 100000;
  limits.max_update_interval_ms = 1000;
  limits.max_waypoints = 64;
  limits.max_eval_samples = 4000;
  limits.max_response_samples = 500;
  limits.max_obstacle_points = 64;
  limits.max_edge_samples = 20000;
  limits.max_table_bytes = size_t{32} << 20;
  limits.max_fleet_missions = 16;
  return limits;
}

// "demo-city" and "geo-city" (the same layers, geo-referenced at 49.6 N,
// 6.1 E); a failure to build them fails the run.
inline std::unique_ptr<server::MapRegistry> FuzzMaps() {
  absl::StatusOr<std::shared_ptr<const RiskMap>> city =
      MakeDemoCity(DemoCityOptions{.size_m = 1000.0, .res_m = 10.0});
  if (!city.ok()) Fail(city.status().ToString());
  MapHeader header = (*city)->header();
  header.name = "geo-city";
  header.geo = GeoReference{49.6, 6.1, "azimuthal equidistant on WGS84 at the origin"};
  absl::StatusOr<std::shared_ptr<const RiskMap>> geo_city =
      RiskMap::Create(std::move(header), (*city)->layers());
  if (!geo_city.ok()) Fail(geo_city.status().ToString());
  absl::StatusOr<std::unique_ptr<server::MapRegistry>> registry =
      server::MapRegistry::FromMaps({*city, *geo_city});
  if (!registry.ok()) Fail(registry.status().ToString());
  return *std::move(registry);
}

}  // namespace riskplan::fuzz

#endif  // RISKPLAN_FUZZ_FUZZ_SERVER_H_
