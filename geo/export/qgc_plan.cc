#include "geo/export/qgc_plan.h"

#include <cmath>

#include "absl/strings/str_format.h"
#include "nlohmann/json.hpp"

namespace riskplan::geo {

absl::StatusOr<std::string> QgcPlanJson(const ExportTrajectory& t, const QgcPlanOptions& o) {
  if (absl::Status s = CheckExportTrajectory(t); !s.ok()) return s;
  for (auto [name, value] : {std::pair{"hold_s", o.hold_s},
                             {"acceptance_radius_m", o.acceptance_radius_m},
                             {"pass_radius_m", o.pass_radius_m},
                             {"hover_speed_mps", o.hover_speed_mps}}) {
    if (!(value >= 0.0) || !std::isfinite(value)) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "QGroundControl plan: %s is %g; it must be finite and >= 0", name, value));
    }
  }
  using Json = nlohmann::ordered_json;
  Json items = Json::array();
  for (size_t k = 0; k < t.samples.size(); ++k) {
    const ExportSample& s = t.samples[k];
    items.push_back({
        {"type", "SimpleItem"},
        {"command", kMavCmdNavWaypoint},
        {"frame", kMavFrameGlobal},
        // Yaw NaN, which QGroundControl writes as null: the vehicle keeps
        // its yaw mode (a fixed wing points along its path anyway).
        {"params",
         {o.hold_s, o.acceptance_radius_m, o.pass_radius_m, nullptr, s.lat_deg, s.lon_deg,
          s.alt_m}},
        {"autoContinue", true},
        {"doJumpId", static_cast<int64_t>(k) + 1},  // from 1, as QGroundControl numbers them
        {"AltitudeMode", kQgcAltitudeModeAbsolute},
        {"Altitude", s.alt_m},
        {"AMSLAltAboveTerrain", nullptr},
    });
  }
  // Home is the ground under the start, or the start's own altitude where
  // the terrain is unknown.
  const ExportSample& start = t.samples.front();
  const double home_alt_m = std::isfinite(start.terrain_m) ? start.terrain_m : start.alt_m;
  Json plan = {
      {"fileType", "Plan"},
      {"version", 1},
      {"groundStation", "riskplan"},
      {"mission",
       {
           {"version", 2},
           {"firmwareType", o.firmware_type},
           {"vehicleType", kMavTypeFixedWing},  // riskplan plans for small fixed wings
           {"cruiseSpeed", t.airspeed_mps},
           {"hoverSpeed", o.hover_speed_mps},
           {"globalPlanAltitudeMode", kQgcAltitudeModeAbsolute},
           {"plannedHomePosition", {start.lat_deg, start.lon_deg, home_alt_m}},
           {"items", std::move(items)},
       }},
      // Optional in the format; written empty so that QGroundControl opens the
      // file without asking.
      {"geoFence", {{"version", 2}, {"circles", Json::array()}, {"polygons", Json::array()}}},
      {"rallyPoints", {{"version", 2}, {"points", Json::array()}}},
  };
  return plan.dump(2) + "\n";
}

absl::StatusOr<int> FirmwareTypeFromName(const std::string& name) {
  if (name == "px4") return kMavAutopilotPx4;
  if (name == "ardupilot") return kMavAutopilotArdupilotMega;
  if (name == "generic") return kMavAutopilotGeneric;
  return absl::InvalidArgumentError(absl::StrFormat(
      "firmware '%s' is unknown; known: px4 (MAV_AUTOPILOT 12), ardupilot (3), generic (0)", name));
}

}  // namespace riskplan::geo
