#include "geo/export/qgc_mission.h"

#include <cmath>
#include <limits>
#include <set>
#include <utility>

#include "absl/strings/str_format.h"
#include "geo/export/qgc_plan.h"
#include "nlohmann/json.hpp"

namespace riskplan::geo {
namespace {

using Json = nlohmann::ordered_json;

constexpr int kMavFrameGlobalRelativeAlt = 3;
constexpr int kMavFrameGlobalInt = 5;
constexpr int kMavFrameGlobalRelativeAltInt = 6;
constexpr int kMavFrameGlobalTerrainAlt = 10;
constexpr int kMavFrameGlobalTerrainAltInt = 11;

// Commands that do not move the aircraft, passed through unchanged.
const std::set<int>& PassThrough() {
  static const auto* commands =
      new std::set<int>{189, 206, 203, 2000, 2001, 183, 201, 195, 197, 530, 1000};
  return *commands;
}

// Names of the commands an error is likely to meet.
std::string CommandName(int command) {
  switch (command) {
    case 16: return "NAV_WAYPOINT";
    case 17: return "NAV_LOITER_UNLIM";
    case 18: return "NAV_LOITER_TURNS";
    case 19: return "NAV_LOITER_TIME";
    case 20: return "NAV_RETURN_TO_LAUNCH";
    case 21: return "NAV_LAND";
    case 22: return "NAV_TAKEOFF";
    case 31: return "NAV_LOITER_TO_ALT";
    case 82: return "NAV_SPLINE_WAYPOINT";
    case 84: return "NAV_VTOL_TAKEOFF";
    case 85: return "NAV_VTOL_LAND";
    case 93: return "NAV_DELAY";
    case 112: return "CONDITION_DELAY";
    case 177: return "DO_JUMP";
    case 178: return "DO_CHANGE_SPEED";
    case 3000: return "DO_VTOL_TRANSITION";
    default: return "MAV_CMD " + std::to_string(command);
  }
}

class ItemError {
 public:
  ItemError(size_t index, const Json& item) : index_(index) {
    if (item.is_object() && item.contains("doJumpId") && item["doJumpId"].is_number_integer()) {
      jump_ = item["doJumpId"].get<int64_t>();
    }
  }
  absl::Status operator()(const std::string& what) const {
    return absl::InvalidArgumentError(
        jump_ >= 0 ? absl::StrFormat("mission item %d (doJumpId %d): %s", index_, jump_, what)
                   : absl::StrFormat("mission item %d: %s", index_, what));
  }

 private:
  size_t index_;
  int64_t jump_ = -1;
};

// params[k] as a number; NaN for null (QGroundControl writes NaN as null).
bool Param(const Json& params, size_t k, double* out) {
  if (!params.is_array() || k >= params.size()) return false;
  const Json& v = params[k];
  if (v.is_null()) {
    *out = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  if (!v.is_number()) return false;
  *out = v.get<double>();
  return true;
}

bool IntField(const Json& object, const char* key, int64_t* out) {
  if (!object.contains(key)) return false;
  const Json& v = object[key];
  if (v.is_number_integer()) {
    *out = v.get<int64_t>();
    return true;
  }
  if (v.is_number_float()) {
    const double d = v.get<double>();
    if (d == std::floor(d) && std::fabs(d) < 1e9) {
      *out = static_cast<int64_t>(d);
      return true;
    }
  }
  return false;
}

absl::Status CheckLatLon(const ItemError& error, double lat, double lon) {
  if (!(lat >= -90.0 && lat <= 90.0) || !(lon >= -180.0 && lon <= 180.0)) {
    return error(absl::StrFormat(
        "position (latitude %g, longitude %g) is not a WGS84 position: latitude must be in "
        "[-90, 90] and longitude in [-180, 180] degrees",
        lat, lon));
  }
  return absl::OkStatus();
}

// The point of a navigation item (16, 21, 22), its frame resolved.
absl::Status ReadPosition(const ItemError& error, const Json& item, int64_t command,
                          const QgcMission& mission, MissionPoint* point) {
  int64_t frame = 0;
  if (!IntField(item, "frame", &frame)) return error("its 'frame' is missing or not an integer");
  const Json& params = item.contains("params") ? item["params"] : Json();
  if (!params.is_array() || params.size() != 7) {
    return error("its 'params' must be an array of 7 values");
  }
  double lat = 0.0;
  double lon = 0.0;
  double alt = 0.0;
  if (!Param(params, 4, &lat) || !Param(params, 5, &lon) || !Param(params, 6, &alt) ||
      !std::isfinite(alt)) {
    return error("params 5-7 (latitude, longitude, altitude) must be numbers");
  }
  // A takeoff or landing at 0, 0 (or without a position) is at home.
  const bool at_home = (command == kMavCmdNavTakeoff || command == kMavCmdNavLand) &&
                       ((lat == 0.0 && lon == 0.0) || (std::isnan(lat) && std::isnan(lon)));
  if (at_home) {
    lat = mission.home_lat_deg;
    lon = mission.home_lon_deg;
  } else if (absl::Status s = CheckLatLon(error, lat, lon); !s.ok()) {
    return s;
  }
  switch (frame) {
    case kMavFrameGlobal:
    case kMavFrameGlobalInt:
      break;
    case kMavFrameGlobalRelativeAlt:
    case kMavFrameGlobalRelativeAltInt:
      alt += mission.home_alt_m;
      break;
    case kMavFrameGlobalTerrainAlt:
    case kMavFrameGlobalTerrainAltInt:
      return error(absl::StrFormat(
          "altitude frame %d (above terrain) is not supported: riskplan plans altitudes above "
          "mean sea level; use frame 0 (absolute) or 3 (relative to home)",
          frame));
    default:
      return error(absl::StrFormat(
          "altitude frame %d is not supported: use 0 (absolute) or 3 (relative to home)", frame));
  }
  point->lat_deg = lat;
  point->lon_deg = lon;
  point->alt_m = alt;
  if (command == kMavCmdNavWaypoint) {
    double yaw = 0.0;
    if (!Param(params, 3, &yaw)) return error("param 4 (yaw) must be a number or null");
    if (std::isfinite(yaw)) {
      double deg = std::fmod(yaw, 360.0);
      if (deg < 0.0) deg += 360.0;
      point->heading_deg = deg;
    }
  }
  return absl::OkStatus();
}

absl::Status ReadHeader(const Json& root, QgcMission* out, const Json** items) {
  if (!root.is_object()) return absl::InvalidArgumentError(".plan: the file is not a JSON object");
  if (!root.contains("fileType") || root["fileType"] != "Plan") {
    return absl::InvalidArgumentError(
        ".plan: 'fileType' must be \"Plan\" (is this a QGroundControl plan file?)");
  }
  int64_t version = 0;
  if (!IntField(root, "version", &version) || version != 1) {
    return absl::InvalidArgumentError(absl::StrFormat(
        ".plan: 'version' is %s; riskplan reads plan files of version 1",
        root.contains("version") ? root["version"].dump() : "missing"));
  }
  if (!root.contains("mission") || !root["mission"].is_object()) {
    return absl::InvalidArgumentError(".plan: 'mission' is missing or not an object");
  }
  const Json& mission = root["mission"];
  if (!IntField(mission, "version", &version) || version != 2) {
    return absl::InvalidArgumentError(absl::StrFormat(
        ".plan: 'mission.version' is %s; riskplan reads missions of version 2",
        mission.contains("version") ? mission["version"].dump() : "missing"));
  }
  const Json& home = mission.contains("plannedHomePosition") ? mission["plannedHomePosition"]
                                                             : Json();
  if (!home.is_array() || home.size() != 3 || !home[0].is_number() || !home[1].is_number() ||
      !home[2].is_number()) {
    return absl::InvalidArgumentError(
        ".plan: 'mission.plannedHomePosition' must be [latitude, longitude, altitude]");
  }
  out->home_lat_deg = home[0].get<double>();
  out->home_lon_deg = home[1].get<double>();
  out->home_alt_m = home[2].get<double>();
  if (!(out->home_lat_deg >= -90.0 && out->home_lat_deg <= 90.0) ||
      !(out->home_lon_deg >= -180.0 && out->home_lon_deg <= 180.0) ||
      !std::isfinite(out->home_alt_m)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        ".plan: 'mission.plannedHomePosition' (%g, %g, %g) is not a WGS84 position",
        out->home_lat_deg, out->home_lon_deg, out->home_alt_m));
  }
  if (mission.contains("cruiseSpeed") && mission["cruiseSpeed"].is_number()) {
    out->cruise_speed_mps = mission["cruiseSpeed"].get<double>();
  }
  int64_t value = 0;
  if (IntField(mission, "firmwareType", &value)) out->firmware_type = static_cast<int>(value);
  if (IntField(mission, "vehicleType", &value)) out->vehicle_type = static_cast<int>(value);
  if (!mission.contains("items") || !mission["items"].is_array()) {
    return absl::InvalidArgumentError(".plan: 'mission.items' is missing or not an array");
  }
  if (mission["items"].size() > kMaxQgcItems) {
    return absl::InvalidArgumentError(absl::StrFormat(
        ".plan: %d mission items; riskplan reads at most %d", mission["items"].size(),
        kMaxQgcItems));
  }
  *items = &mission["items"];
  return absl::OkStatus();
}

}  // namespace

std::string_view MissionPointKindName(MissionPointKind kind) {
  switch (kind) {
    case MissionPointKind::kTakeoff: return "takeoff";
    case MissionPointKind::kWaypoint: return "waypoint";
    case MissionPointKind::kLand: return "land";
    case MissionPointKind::kReturnToLaunch: return "return to launch";
  }
  return "unknown";
}

absl::StatusOr<QgcMission> ParseQgcPlan(std::string_view text) {
  Json root;
  try {
    root = Json::parse(text.begin(), text.end());
  } catch (const Json::parse_error& e) {
    return absl::InvalidArgumentError(
        absl::StrFormat(".plan: not JSON (at byte %d): %s", e.byte, e.what()));
  }
  QgcMission out;
  const Json* items = nullptr;
  if (absl::Status s = ReadHeader(root, &out, &items); !s.ok()) return s;

  // A plan riskplan wrote: only the listed items are the mission's own.
  std::optional<std::set<int64_t>> own;
  if (root.contains("riskplan") && root["riskplan"].is_object() &&
      root["riskplan"].contains("mission_items") && root["riskplan"]["mission_items"].is_array()) {
    own.emplace();
    for (const Json& id : root["riskplan"]["mission_items"]) {
      if (id.is_number_integer()) own->insert(id.get<int64_t>());
    }
  }

  std::optional<size_t> end_item;  // the land or return item, once read
  for (size_t i = 0; i < items->size(); ++i) {
    const Json& item = (*items)[i];
    const ItemError error(i, item);
    if (!item.is_object()) return error("it is not a JSON object");
    const std::string type = item.contains("type") && item["type"].is_string()
                                 ? item["type"].get<std::string>()
                                 : std::string();
    if (type == "ComplexItem") {
      const std::string kind = item.contains("complexItemType") && item["complexItemType"].is_string()
                                   ? item["complexItemType"].get<std::string>()
                                   : "unknown";
      return error(absl::StrFormat(
          "complex item '%s' cannot be planned by riskplan: it flies a pattern of its own; "
          "replace it with waypoints",
          kind));
    }
    if (type != "SimpleItem") {
      return error(absl::StrFormat("'type' is %s; riskplan reads SimpleItem items",
                                   item.contains("type") ? item["type"].dump() : "missing"));
    }
    int64_t command = 0;
    if (!IntField(item, "command", &command)) {
      return error("its 'command' is missing or not an integer");
    }
    if (PassThrough().count(static_cast<int>(command)) != 0) {
      if (out.points.empty()) {
        out.leading.push_back(item.dump());
      } else {
        out.points.back().following.push_back(item.dump());
      }
      continue;
    }
    MissionPoint point;
    point.item = i;
    point.item_json = item.dump();
    switch (command) {
      case kMavCmdNavWaypoint: point.kind = MissionPointKind::kWaypoint; break;
      case kMavCmdNavTakeoff: point.kind = MissionPointKind::kTakeoff; break;
      case kMavCmdNavLand: point.kind = MissionPointKind::kLand; break;
      case kMavCmdNavReturnToLaunch: point.kind = MissionPointKind::kReturnToLaunch; break;
      default:
        return error(absl::StrFormat(
            "command %d (%s) cannot be planned by riskplan: it reads waypoints (16), takeoff "
            "(22), land (21) and return to launch (20), and passes camera and marker commands "
            "through (docs/geodata.md)",
            command, CommandName(static_cast<int>(command))));
    }
    if (end_item.has_value()) {
      return error(absl::StrFormat("%s after the mission's end (item %d)",
                                   std::string(MissionPointKindName(point.kind)), *end_item));
    }
    if (point.kind == MissionPointKind::kTakeoff && !out.points.empty()) {
      return error("takeoff after the mission's first point: a takeoff must come first");
    }
    if (point.kind == MissionPointKind::kReturnToLaunch) {
      if (out.points.empty()) return error("return to launch with no point before it");
      // Home, at the altitude of the point before: riskplan plans the way
      // back to above home; the autopilot lands.
      point.lat_deg = out.home_lat_deg;
      point.lon_deg = out.home_lon_deg;
      point.alt_m = out.points.back().alt_m;
    } else if (absl::Status s = ReadPosition(error, item, command, out, &point); !s.ok()) {
      return s;
    }
    // In a plan riskplan wrote, a waypoint it did not list is a point of the
    // route between two of the mission's own: not part of the mission.
    int64_t jump = -1;
    IntField(item, "doJumpId", &jump);
    if (own.has_value() && own->count(jump) == 0) continue;
    if (point.kind == MissionPointKind::kLand || point.kind == MissionPointKind::kReturnToLaunch) {
      end_item = i;
    }
    out.points.push_back(std::move(point));
  }
  if (out.points.size() < 2) {
    return absl::InvalidArgumentError(absl::StrFormat(
        ".plan: the mission has %d point(s) riskplan can plan; it needs at least two (a start "
        "and an end: takeoff or waypoint, then waypoints, land or return to launch)",
        out.points.size()));
  }
  return out;
}

absl::StatusOr<std::string> QgcMissionPlanJson(const QgcMission& mission,
                                               const ExportTrajectory& route,
                                               const std::vector<size_t>& leg_end_sample) {
  if (absl::Status s = CheckExportTrajectory(route); !s.ok()) return s;
  if (mission.points.size() < 2 || leg_end_sample.size() + 1 != mission.points.size()) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "QGroundControl mission: %d mission points need %d leg ends; %d given",
        mission.points.size(), mission.points.size() - 1, leg_end_sample.size()));
  }
  for (size_t i = 0; i < leg_end_sample.size(); ++i) {
    const size_t previous = i == 0 ? 0 : leg_end_sample[i - 1];
    if (leg_end_sample[i] <= previous || leg_end_sample[i] >= route.samples.size()) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "QGroundControl mission: leg %d ends at sample %d, which is not after sample %d and "
          "within the route's %d samples",
          i + 1, leg_end_sample[i], previous, route.samples.size()));
    }
  }
  if (leg_end_sample.back() != route.samples.size() - 1) {
    return absl::InvalidArgumentError(
        "QGroundControl mission: the last leg must end at the route's last sample");
  }

  Json items = Json::array();
  Json own = Json::array();
  int64_t jump = 0;
  auto append = [&](Json item) {
    item["doJumpId"] = ++jump;
    items.push_back(std::move(item));
  };
  auto at = [&](Json item, const ExportSample& s) {
    item["frame"] = kMavFrameGlobal;
    item["params"][4] = s.lat_deg;
    item["params"][5] = s.lon_deg;
    item["params"][6] = s.alt_m;
    item["AltitudeMode"] = kQgcAltitudeModeAbsolute;
    item["Altitude"] = s.alt_m;
    item["AMSLAltAboveTerrain"] = nullptr;
    return item;
  };
  auto route_point = [&](const ExportSample& s) {
    append(Json{{"type", "SimpleItem"},
                {"command", kMavCmdNavWaypoint},
                {"frame", kMavFrameGlobal},
                {"params", {0.0, 0.0, 0.0, nullptr, s.lat_deg, s.lon_deg, s.alt_m}},
                {"autoContinue", true},
                {"doJumpId", 0},
                {"AltitudeMode", kQgcAltitudeModeAbsolute},
                {"Altitude", s.alt_m},
                {"AMSLAltAboveTerrain", nullptr}});
  };
  auto own_point = [&](const MissionPoint& p, const ExportSample& s) {
    Json item = Json::parse(p.item_json);
    if (p.kind != MissionPointKind::kReturnToLaunch) item = at(std::move(item), s);
    append(std::move(item));
    own.push_back(jump);
    for (const std::string& f : p.following) append(Json::parse(f));
  };
  for (const std::string& f : mission.leading) append(Json::parse(f));
  own_point(mission.points[0], route.samples[0]);
  size_t previous = 0;
  for (size_t i = 0; i < leg_end_sample.size(); ++i) {
    for (size_t k = previous + 1; k < leg_end_sample[i]; ++k) route_point(route.samples[k]);
    own_point(mission.points[i + 1], route.samples[leg_end_sample[i]]);
    previous = leg_end_sample[i];
  }

  Json plan = {
      {"fileType", "Plan"},
      {"version", 1},
      {"groundStation", "riskplan"},
      {"mission",
       {
           {"version", 2},
           {"firmwareType", mission.firmware_type},
           {"vehicleType", kMavTypeFixedWing},
           {"cruiseSpeed", route.airspeed_mps},
           {"hoverSpeed", 0.0},
           {"globalPlanAltitudeMode", kQgcAltitudeModeAbsolute},
           {"plannedHomePosition", {mission.home_lat_deg, mission.home_lon_deg, mission.home_alt_m}},
           {"items", std::move(items)},
       }},
      {"geoFence", {{"version", 2}, {"circles", Json::array()}, {"polygons", Json::array()}}},
      {"rallyPoints", {{"version", 2}, {"points", Json::array()}}},
      // QGroundControl ignores keys it does not know; riskplan reads this
      // back to tell the mission's own items from the route's points.
      {"riskplan", {{"version", 1}, {"mission_items", std::move(own)}}},
  };
  return plan.dump(2) + "\n";
}

}  // namespace riskplan::geo
