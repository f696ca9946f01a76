// WGS84 fields of requests, into the map's local frame (docs/api.md,
// "WGS84"): the checks of their numbers, the conversion through the map's
// GeoFrame, and errors that name the request field, the map and the value.
#ifndef RISKPLAN_SERVER_API_WGS84_FIELDS_H_
#define RISKPLAN_SERVER_API_WGS84_FIELDS_H_

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/map/risk_map.h"
#include "geo/geo_frame.h"
#include "riskplan/v1/planner.pb.h"
#include "server/models/map_registry.h"

namespace riskplan::server {

// The frame of `map` for a request field given in WGS84: INVALID_ARGUMENT
// naming the field and the map when the map has no geo-reference, e.g.
// "start_wgs84: map 'demo-city' has no geo-reference, so it takes positions
// in its local metres only (start)".
absl::StatusOr<std::shared_ptr<const geo::GeoFrame>> FrameForField(const MapRegistry& registry,
                                                                   const RiskMap& map,
                                                                   std::string_view field,
                                                                   std::string_view local_field);

// The numbers of a WGS84 pose, checked: every one finite, the latitude in
// [-90, 90], the longitude in [-180, 180]; errors name "FIELD.lat_deg" and
// the value.
absl::StatusOr<geo::GeoPose> GeoPoseFromProto(const v1::GeoPose& pose, std::string_view field);

// Checked WGS84 poses into the local frame (GeoFrame::ToLocal); errors (a
// pose over 1000 km from the map's origin, a heading at a pole) are prefixed
// by `field`, and name the pose by index unless `single`.
absl::StatusOr<std::vector<Pose>> PosesFromWgs84(const geo::GeoFrame& frame,
                                                 const std::vector<geo::GeoPose>& poses,
                                                 std::string_view field, bool single);

// A latitude in [-90, 90] and a longitude in [-180, 180], else
// INVALID_ARGUMENT naming "FIELD.lat_deg" (or ".lon_deg") and the value.
absl::Status CheckLatLon(double lat, double lon, const std::string& field);

// WGS84 points (polyline points, obstacles, a region's edges) into the local
// frame; errors as PosesFromWgs84's.
absl::StatusOr<std::vector<geo::LocalXY>> PointsFromWgs84(const geo::GeoFrame& frame,
                                                          const std::vector<geo::LatLon>& points,
                                                          std::string_view field);

// INVALID_ARGUMENT when `pose`, given as `given` in WGS84, lies outside
// `map`: the message gives both frames and the map's WGS84 box.
absl::Status CheckWgs84InsideMap(const RiskMap& map, const geo::GeoFrame& frame, const Pose& pose,
                                 const geo::GeoPose& given, std::string_view field);

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_API_WGS84_FIELDS_H_
