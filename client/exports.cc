#include "client/exports.h"

#include <cmath>
#include <cstdio>

#include "absl/strings/str_format.h"
#include "geo/export/geojson.h"
#include "geo/export/kml.h"

namespace riskplan::client {

absl::Status CheckExportFiles(const std::string& firmware_name, ExportFiles* files) {
  if (!files->any()) return absl::OkStatus();
  if (!(files->spacing_m >= 1.0 && files->spacing_m <= 100000.0)) {
    return absl::InvalidArgumentError(
        absl::StrFormat("--export_spacing_m=%g: must be in [1, 100000] m", files->spacing_m));
  }
  absl::StatusOr<int> firmware = geo::FirmwareTypeFromName(firmware_name);
  if (!firmware.ok()) {
    return absl::InvalidArgumentError(
        absl::StrFormat("--plan_firmware: %s", firmware.status().message()));
  }
  files->plan_options.firmware_type = *firmware;
  return absl::OkStatus();
}

absl::Status CheckMapHasGeo(RiskplanClient& client, const std::string& map) {
  v1::ListMapsResponse maps;
  if (grpc::Status s = client.ListMaps(&maps); !s.ok()) {
    return absl::UnavailableError(absl::StrFormat("ListMaps failed: %s", s.error_message()));
  }
  for (const v1::MapInfo& m : maps.maps()) {
    if (m.name() != map) continue;
    if (m.has_geo()) return absl::OkStatus();
    return absl::FailedPreconditionError(absl::StrFormat(
        "--plan_out, --geojson_out, --kml_out: map '%s' has no geo-reference, so its "
        "trajectories have no WGS84 coordinates to export",
        map));
  }
  return absl::OkStatus();  // an unknown map: the plan's own error says so
}

absl::StatusOr<geo::ExportTrajectory> ExportTrajectoryOf(const v1::EvaluateRiskResponse& response,
                                                         const std::string& map,
                                                         const std::string& description,
                                                         double spacing_m) {
  if (response.path_size() < 2) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "the evaluation returned a path of %d poses; an export needs at least 2 (a trajectory of "
        "length 0, or no path_spacing_m)",
        response.path_size()));
  }
  geo::ExportTrajectory t;
  t.map = map;
  t.description = description;
  t.spacing_m = spacing_m;
  t.risk = response.risk();
  t.length_m = response.length_m();
  t.flight_time_s = response.flight_time_s();
  t.risk_per_flight_hour = response.risk_per_flight_hour();
  t.airspeed_mps = response.airspeed_mps();
  t.wind_speed_mps = response.wind().speed_mps();
  t.wind_from_true_deg = response.wind().has_from_true_deg() ? response.wind().from_true_deg()
                                                             : response.wind().from_deg();
  t.samples.reserve(response.path_size());
  for (const v1::PathSample& p : response.path()) {
    // The server sets every pose's WGS84 form on a geo-referenced map, and
    // none without one.
    if (!p.has_wgs84()) {
      return absl::FailedPreconditionError(absl::StrFormat(
          "map '%s' has no geo-reference, so its trajectories have no WGS84 coordinates to "
          "export (riskplan maps shows which maps have one)",
          map));
    }
    t.samples.push_back(geo::ExportSample{
        .lat_deg = p.wgs84().lat_deg(),
        .lon_deg = p.wgs84().lon_deg(),
        .alt_m = p.wgs84().alt_m(),
        .heading_deg = p.wgs84().heading_deg(),
        .arc_length_m = p.arc_length_m(),
        .risk = p.risk(),
        .risk_defined = p.defined(),
        .terrain_m = p.terrain_m(),
    });
  }
  return t;
}

absl::Status WriteExports(const ExportFiles& files, const geo::ExportTrajectory& trajectory,
                          bool quiet) {
  struct Output {
    const std::string& path;
    const char* what;
    absl::StatusOr<std::string> text;
  };
  Output outputs[] = {
      {files.plan_out, "QGroundControl plan",
       files.plan_out.empty() ? absl::StatusOr<std::string>("")
                              : geo::QgcPlanJson(trajectory, files.plan_options)},
      {files.geojson_out, "GeoJSON",
       files.geojson_out.empty() ? absl::StatusOr<std::string>("")
                                 : geo::TrajectoryGeoJson(trajectory)},
      {files.kml_out, "KML",
       files.kml_out.empty() ? absl::StatusOr<std::string>("") : geo::TrajectoryKml(trajectory)},
  };
  for (Output& o : outputs) {
    if (o.path.empty()) continue;
    if (!o.text.ok()) return o.text.status();
    if (absl::Status s = geo::WriteTextFileAtomically(*o.text, o.path); !s.ok()) return s;
    if (quiet) continue;
    std::printf("%s: %s (%d waypoints every %g m)\n", o.what, o.path.c_str(),
                static_cast<int>(trajectory.samples.size()), trajectory.spacing_m);
  }
  return absl::OkStatus();
}

std::string WindText(const v1::WindReport& w) {
  return absl::StrFormat(
      "wind %g m/s from %.1f deg (grid north%s), the air moving to (%.2f, %.2f) m/s; airspeed %g "
      "m/s",
      w.speed_mps(), w.from_deg(),
      w.has_from_true_deg() ? absl::StrFormat("; %.1f deg true", w.from_true_deg()) : "",
      w.x_mps(), w.y_mps(), w.airspeed_mps());
}

std::string TargetLevelOfSafetyText(double risk_per_flight_hour, double flight_time_s,
                                    double airspeed_mps, double target_per_hour) {
  const std::string head = absl::StrFormat(
      "risk per flight hour %.3g (flight time %.1f s at %g m/s): ", risk_per_flight_hour,
      flight_time_s, airspeed_mps);
  if (risk_per_flight_hour <= target_per_hour) {
    return head + absl::StrFormat("meets the target level of safety of %g per flight hour",
                                  target_per_hour);
  }
  return head + absl::StrFormat(
                    "does NOT meet the target level of safety of %g per flight hour (%.3g times "
                    "it)",
                    target_per_hour, risk_per_flight_hour / target_per_hour);
}

}  // namespace riskplan::client
