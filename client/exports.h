// The CLI's ground-station and GIS exports (`riskplan plan` and `eval` with
// --plan_out, --geojson_out, --kml_out): EvaluateRiskResponse.path, which the
// server sampled in both frames, turned into the writers' plain values
// (geo/export/) and written. Also the target level of safety's verdict.
#ifndef RISKPLAN_CLIENT_EXPORTS_H_
#define RISKPLAN_CLIENT_EXPORTS_H_

#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "client/client.h"
#include "geo/export/export_trajectory.h"
#include "geo/export/qgc_plan.h"
#include "riskplan/v1/planner.pb.h"

namespace riskplan::client {

struct ExportFiles {
  std::string plan_out;     // QGroundControl .plan
  std::string geojson_out;  // GeoJSON
  std::string kml_out;      // KML
  double spacing_m = 50.0;  // EvaluateRiskRequest.path_spacing_m
  geo::QgcPlanOptions plan_options;

  bool any() const { return !plan_out.empty() || !geojson_out.empty() || !kml_out.empty(); }
};

// Checks `files` before any call (when it names a file: the spacing in [1,
// 100000] m) and sets its .plan's firmwareType from `firmware_name` (px4,
// ardupilot, generic). InvalidArgument naming the flag otherwise.
absl::Status CheckExportFiles(const std::string& firmware_name, ExportFiles* files);

// OK when `map` has a geo-reference (asked with ListMaps before a plan whose
// result is to be exported, so that a plan of many seconds is not run for
// nothing), or is not served (the plan's own error says so);
// FailedPrecondition naming the map when it has none; Unavailable when
// ListMaps fails.
absl::Status CheckMapHasGeo(RiskplanClient& client, const std::string& map);

// The trajectory of `response` (EvaluateRisk with path_spacing_m) for the
// writers. FailedPrecondition naming `map` when its path has no WGS84 poses
// (the map has no geo-reference), InvalidArgument when it has fewer than 2.
absl::StatusOr<geo::ExportTrajectory> ExportTrajectoryOf(const v1::EvaluateRiskResponse& response,
                                                         const std::string& map,
                                                         const std::string& description,
                                                         double spacing_m);

// Writes every file `files` names (each atomically); the first failure is
// returned and names the file. Prints one line per file written on stdout
// unless `quiet` (--json output must stay one JSON document).
absl::Status WriteExports(const ExportFiles& files, const geo::ExportTrajectory& trajectory,
                          bool quiet = false);

// The line comparing a risk per flight hour with a target level of safety
// (expected casualties per flight hour), e.g. "risk per flight hour
// 2.35e-07 (flight time 612.3 s at 18 m/s): meets the target level of
// safety of 1e-06 per flight hour".
// One line for an answer's wind: "wind 8 m/s from 270.0 deg (grid north;
// 270.0 deg true), the air moving to (8.00, -0.00) m/s; airspeed 18 m/s".
std::string WindText(const v1::WindReport& wind);

std::string TargetLevelOfSafetyText(double risk_per_flight_hour, double flight_time_s,
                                    double airspeed_mps, double target_per_hour);

}  // namespace riskplan::client

#endif  // RISKPLAN_CLIENT_EXPORTS_H_
