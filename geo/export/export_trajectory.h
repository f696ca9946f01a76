// A trajectory ready for ground stations and GIS: the flown path sampled in
// WGS84 with each pose's configuration risk and the flight's totals. Plain
// values, with no dependency on core, GDAL or the API, so that the client
// (which links neither core nor GDAL) and the tools share the writers of
// qgc_plan.h, geojson.h and kml.h.
#ifndef RISKPLAN_GEO_EXPORT_EXPORT_TRAJECTORY_H_
#define RISKPLAN_GEO_EXPORT_EXPORT_TRAJECTORY_H_

#include <string>
#include <vector>

#include "absl/status/status.h"

namespace riskplan::geo {

// One pose of the sampled path.
struct ExportSample {
  double lat_deg = 0.0;       // WGS84
  double lon_deg = 0.0;       // WGS84
  double alt_m = 0.0;         // m above mean sea level
  double heading_deg = 0.0;   // clockwise from true north
  double arc_length_m = 0.0;  // from the start of the trajectory
  // M(q): expected casualties given a failure at this pose; meaningful only
  // when risk_defined.
  double risk = 0.0;
  bool risk_defined = true;
  double terrain_m = 0.0;  // m AMSL under the pose; NaN when unknown
};

struct ExportTrajectory {
  std::string map;          // the map's name
  std::string description;  // free text: what made it (e.g. "riskplan plan, RISK_RRT_STAR")
  std::vector<ExportSample> samples;  // start ... goal
  double spacing_m = 0.0;             // arc length between samples (the last gap may be shorter)
  double risk = 0.0;                  // expected casualties per flight
  double length_m = 0.0;              // 3-D length, m
  // The evaluation's time: length_m / airspeed_mps in still air, the sum of
  // ds / ground speed in wind.
  double flight_time_s = 0.0;
  double risk_per_flight_hour = 0.0;  // risk / flight hours
  // The cruise airspeed, the speed a ground station flies at (QGroundControl's
  // cruiseSpeed); in wind the ground speed varies along the track, which the
  // samples follow (they are the ground track, headings over the ground).
  double airspeed_mps = 0.0;
  // The mean wind it was planned and evaluated in: speed, m/s (0: still air,
  // and the writers then write no wind), and the direction it blows from,
  // degrees clockwise from true north.
  double wind_speed_mps = 0.0;
  double wind_from_true_deg = 0.0;
};

// OK when the trajectory can be written: at least 2 samples, every latitude
// in [-90, 90], longitude in [-180, 180], altitude and heading finite, the
// totals finite. InvalidArgument naming the first bad sample otherwise.
absl::Status CheckExportTrajectory(const ExportTrajectory& trajectory);

// Writes `text` to `path` through a temporary file in the same directory
// renamed over it, so that a reader never sees half a file. Unavailable
// (naming the path and the system's reason) when it cannot.
absl::Status WriteTextFileAtomically(const std::string& text, const std::string& path);

}  // namespace riskplan::geo

#endif  // RISKPLAN_GEO_EXPORT_EXPORT_TRAJECTORY_H_
