// GeoJSON (RFC 7946) of a trajectory, for GIS tools.
//
// A FeatureCollection of:
//   - one Feature with a LineString geometry (the whole path, in order) and
//     the flight's properties: "kind": "trajectory", "map", "description",
//     "risk" (expected casualties per flight), "length_m", "flight_time_s",
//     "risk_per_flight_hour", "airspeed_mps", "spacing_m" (in wind also
//     "wind_speed_mps", "wind_from_true_deg"), and one array per
//     sample quantity, index for index with the coordinates: "alt_amsl_m",
//     "heading_deg", "arc_length_m", "sample_risk" (M, null where undefined);
//   - one Feature per sample with a Point geometry and "kind": "sample",
//     "index", "alt_amsl_m", "heading_deg", "arc_length_m", "risk" (M, null
//     where undefined), "terrain_m" (null when unknown), so that a GIS can
//     colour the path by risk.
// Positions are [longitude, latitude] in WGS84 decimal degrees (RFC 7946's
// order and its only CRS; no "crs" member). They have no third element on
// purpose: RFC 7946 makes it the height above the WGS84 ellipsoid, while
// riskplan's altitudes are above mean sea level (tens of metres apart, by the
// geoid); the AMSL altitudes are the "alt_amsl_m" properties instead. Numbers
// are written as the shortest decimals that read back to the same doubles
// (about 1e-15 degrees; RFC 7946 allows the precision).
#ifndef RISKPLAN_GEO_EXPORT_GEOJSON_H_
#define RISKPLAN_GEO_EXPORT_GEOJSON_H_

#include <string>

#include "absl/status/statusor.h"
#include "geo/export/export_trajectory.h"

namespace riskplan::geo {

// The GeoJSON text described above. InvalidArgument when
// CheckExportTrajectory refuses the trajectory.
absl::StatusOr<std::string> TrajectoryGeoJson(const ExportTrajectory& trajectory);

}  // namespace riskplan::geo

#endif  // RISKPLAN_GEO_EXPORT_GEOJSON_H_
