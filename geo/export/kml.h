// KML 2.2 (OGC 07-147r2) of a trajectory, for Google Earth and GIS tools.
//
// A Document holding a Placemark "trajectory" with a LineString (altitudeMode
// absolute: KML's absolute altitudes are above sea level, as riskplan's are)
// and ExtendedData with the flight's totals (risk, length_m, flight_time_s,
// risk_per_flight_hour, airspeed_mps, spacing_m; in wind also wind_speed_mps and
// wind_from_true_deg), then a Folder "samples"
// with one Placemark per sample: a Point (altitudeMode absolute) and
// ExtendedData index, heading_deg, arc_length_m, risk (M; empty where
// undefined), terrain_m. Coordinates are "longitude,latitude,altitude" with
// 10 decimals of a degree (about 0.01 mm) and 4 of a metre.
#ifndef RISKPLAN_GEO_EXPORT_KML_H_
#define RISKPLAN_GEO_EXPORT_KML_H_

#include <string>

#include "absl/status/statusor.h"
#include "geo/export/export_trajectory.h"

namespace riskplan::geo {

// The KML text described above. InvalidArgument when CheckExportTrajectory
// refuses the trajectory.
absl::StatusOr<std::string> TrajectoryKml(const ExportTrajectory& trajectory);

}  // namespace riskplan::geo

#endif  // RISKPLAN_GEO_EXPORT_KML_H_
