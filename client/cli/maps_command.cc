// `riskplan maps`: the maps the server holds, with their size, terrain,
// landing sites and geo-reference (or --json: ListMaps as it came).
#include <cstdio>

#include "absl/strings/str_format.h"
#include "client/cli/command_support.h"
#include "client/cli/commands.h"

namespace riskplan::client {

int RunMaps(const CliOptions& o, RiskplanClient& client) {
  v1::ListMapsResponse response;
  grpc::Status status = client.ListMaps(&response, TimeoutOr(o, absl::Seconds(10)));
  if (!status.ok()) return RpcError(o, "ListMaps", status);
  if (o.json) {
    std::printf("%s\n", ToJson(response).c_str());
    return 0;
  }
  for (const v1::MapInfo& m : response.maps()) {
    std::printf(
        "%s: %.0f x %.0f m (%d x %d cells of %g m), south-west corner (%g, %g), terrain %.1f to "
        "%.1f m AMSL, %d landing sites, %.1f MB\n",
        m.name().c_str(), m.width_m(), m.height_m(), m.nx(), m.ny(), m.resolution_m(), m.x0_m(),
        m.y0_m(), m.terrain_min_m(), m.terrain_max_m(), m.landing_sites_size(),
        m.memory_bytes() / 1e6);
    if (!m.provenance().empty()) std::printf("  provenance: %s\n", m.provenance().c_str());
    if (m.has_geo()) {
      std::printf("  geo-reference: local (%g, %g) m is WGS84 (%.9f, %.9f) deg%s\n",
                  m.geo().origin_x_m(), m.geo().origin_y_m(), m.geo().origin_lat_deg(),
                  m.geo().origin_lon_deg(),
                  m.geo().crs().empty() ? "" : absl::StrFormat(" (%s)", m.geo().crs()).c_str());
    }
    if (m.has_bounds_wgs84()) {
      const v1::GeoBounds& b = m.bounds_wgs84();
      std::printf("  WGS84 extent: latitudes %.7f to %.7f, longitudes %.7f to %.7f\n",
                  b.min_lat_deg(), b.max_lat_deg(), b.min_lon_deg(), b.max_lon_deg());
      if (!m.geo().proj_definition().empty()) {
        std::printf("  local frame: %s\n", m.geo().proj_definition().c_str());
      }
    }
  }
  return 0;
}

}  // namespace riskplan::client
