#include "server/api/wgs84_fields.h"

#include <string>

#include "absl/strings/str_format.h"
#include "server/api/field_checks.h"

namespace riskplan::server {
namespace {

// GeoFrame's batch errors start "pose K: " or "point K: "; for a single pose
// the field alone names it.
absl::Status ConversionError(const absl::Status& status, std::string_view field, bool single) {
  std::string message(status.message());
  if (single) {
    for (const std::string prefix : {"pose 0: ", "point 0: "}) {
      if (message.rfind(prefix, 0) == 0) message = message.substr(prefix.size());
    }
  }
  return absl::Status(status.code(), absl::StrFormat("%s: %s", std::string(field), message));
}

}  // namespace

absl::Status CheckLatLon(double lat, double lon, const std::string& field) {
  if (!(lat >= -90.0 && lat <= 90.0)) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s.lat_deg has value %g; it must be in [-90, 90]", field, lat));
  }
  if (!(lon >= -180.0 && lon <= 180.0)) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s.lon_deg has value %g; it must be in [-180, 180]", field, lon));
  }
  return absl::OkStatus();
}

absl::StatusOr<std::shared_ptr<const geo::GeoFrame>> FrameForField(const MapRegistry& registry,
                                                                   const RiskMap& map,
                                                                   std::string_view field,
                                                                   std::string_view local_field) {
  std::shared_ptr<const geo::GeoFrame> frame = registry.Frame(map.name());
  if (frame != nullptr) return frame;
  return absl::InvalidArgumentError(absl::StrFormat(
      "%s: map '%s' has no geo-reference, so it takes positions in its local metres only (%s)",
      std::string(field), map.name(), std::string(local_field)));
}

absl::StatusOr<geo::GeoPose> GeoPoseFromProto(const v1::GeoPose& pose, std::string_view field) {
  const std::string f(field);
  if (absl::Status s = CheckLatLon(pose.lat_deg(), pose.lon_deg(), f); !s.ok()) return s;
  if (absl::Status s = CheckFinite(pose.alt_m(), f + ".alt_m"); !s.ok()) return s;
  if (absl::Status s = CheckFinite(pose.heading_deg(), f + ".heading_deg"); !s.ok()) return s;
  return geo::GeoPose{pose.lat_deg(), pose.lon_deg(), pose.alt_m(), pose.heading_deg()};
}

absl::StatusOr<std::vector<Pose>> PosesFromWgs84(const geo::GeoFrame& frame,
                                                 const std::vector<geo::GeoPose>& poses,
                                                 std::string_view field, bool single) {
  absl::StatusOr<std::vector<Pose>> local = frame.ToLocal(poses);
  if (!local.ok()) return ConversionError(local.status(), field, single);
  return local;
}

absl::StatusOr<std::vector<geo::LocalXY>> PointsFromWgs84(const geo::GeoFrame& frame,
                                                          const std::vector<geo::LatLon>& points,
                                                          std::string_view field) {
  absl::StatusOr<std::vector<geo::LocalXY>> local = frame.ToLocal(points);
  if (!local.ok()) return ConversionError(local.status(), field, /*single=*/false);
  return local;
}

absl::Status CheckWgs84InsideMap(const RiskMap& map, const geo::GeoFrame& frame, const Pose& pose,
                                 const geo::GeoPose& given, std::string_view field) {
  int i = 0, j = 0;
  if (map.CellOf(pose.x, pose.y, &i, &j)) return absl::OkStatus();
  std::string box;
  absl::StatusOr<geo::GeoBounds> b =
      frame.BoundsOf(map.x0(), map.y0(), map.x0() + map.width_m(), map.y0() + map.height_m());
  if (b.ok()) {
    box = absl::StrFormat(" (latitudes %.6f to %.6f, longitudes %.6f to %.6f)", b->min_lat_deg,
                          b->max_lat_deg, b->min_lon_deg, b->max_lon_deg);
  }
  return absl::InvalidArgumentError(absl::StrFormat(
      "%s (lat, lon) = (%.9g, %.9g) deg, local (x, y) = (%.2f, %.2f) m, is outside map '%s', "
      "which covers x in [%g, %g), y in [%g, %g)%s",
      std::string(field), given.lat_deg, given.lon_deg, pose.x, pose.y, map.name(), map.x0(),
      map.x0() + map.width_m(), map.y0(), map.y0() + map.height_m(), box));
}

}  // namespace riskplan::server
