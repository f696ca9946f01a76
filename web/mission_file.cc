#include "web/mission_file.h"

#include <utility>

#include "absl/strings/str_format.h"
#include "nlohmann/json.hpp"
#include "web/proto_json.h"

namespace riskplan::web {
namespace {

using Json = nlohmann::json;

Json GeoPoseJson(const v1::GeoPose& p) {
  return Json{{"lat_deg", p.lat_deg()},
              {"lon_deg", p.lon_deg()},
              {"alt_m", p.alt_m()},
              {"heading_deg", p.heading_deg()}};
}

}  // namespace

absl::StatusOr<WebMission> ReadMissionFile(std::string_view text) {
  if (text.size() > kMaxMissionFileBytes) {
    return absl::InvalidArgumentError(absl::StrFormat(
        ".plan: the file is %d bytes; this gateway reads missions of at most %d bytes",
        text.size(), kMaxMissionFileBytes));
  }
  absl::StatusOr<geo::QgcMission> parsed = geo::ParseQgcPlan(text);
  if (!parsed.ok()) return parsed.status();
  WebMission out;
  out.mission = *std::move(parsed);
  out.headings_deg = client::MissionHeadings(out.mission);
  out.legs = client::MissionLegs(out.mission, out.headings_deg);
  // ParseQgcPlan read the file as JSON already; the "riskplan" section's
  // limits are the page's own addition.
  const Json root = Json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  if (root.is_object() && root.contains("riskplan") && root["riskplan"].is_object() &&
      root["riskplan"].contains("limits")) {
    const Json& limits = root["riskplan"]["limits"];
    if (!limits.is_object()) {
      return absl::InvalidArgumentError(
          ".plan: 'riskplan.limits' must be an object of FlightLimits fields (max_flight_time_s, "
          "max_length_m, max_risk, max_risk_per_flight_hour, objective, pareto)");
    }
    if (absl::Status s = FromJson(limits.dump(), &out.limits); !s.ok()) {
      return absl::InvalidArgumentError(
          absl::StrFormat(".plan: 'riskplan.limits': %s", s.message()));
    }
    out.has_limits = true;
  }
  return out;
}

std::string MissionJson(const WebMission& m) {
  Json points = Json::array();
  for (size_t k = 0; k < m.mission.points.size(); ++k) {
    const geo::MissionPoint& p = m.mission.points[k];
    points.push_back(Json{{"item", p.item},
                          {"kind", std::string(geo::MissionPointKindName(p.kind))},
                          {"name", client::MissionItemName(p)},
                          {"lat_deg", p.lat_deg},
                          {"lon_deg", p.lon_deg},
                          {"alt_m", p.alt_m},
                          {"heading_deg", m.headings_deg[k]},
                          {"heading_given", p.heading_deg.has_value()}});
  }
  Json legs = Json::array();
  for (size_t i = 0; i < m.legs.size(); ++i) {
    legs.push_back(Json{{"from", m.legs[i].from},
                        {"to", m.legs[i].to},
                        {"name", LegName(m, i)},
                        {"start", GeoPoseJson(m.legs[i].start)},
                        {"goal", GeoPoseJson(m.legs[i].goal)}});
  }
  Json out = {{"home",
               {{"lat_deg", m.mission.home_lat_deg},
                {"lon_deg", m.mission.home_lon_deg},
                {"alt_m", m.mission.home_alt_m}}},
              {"cruise_speed_mps", m.mission.cruise_speed_mps},
              {"points", std::move(points)},
              {"legs", std::move(legs)}};
  if (m.has_limits) out["limits"] = Json::parse(ToJson(m.limits));
  return out.dump(-1, ' ', false, Json::error_handler_t::replace);
}

std::string LegName(const WebMission& m, size_t leg) {
  return absl::StrFormat("leg %d (%s -> %s)", leg + 1,
                         client::MissionItemName(m.mission.points[m.legs[leg].from]),
                         client::MissionItemName(m.mission.points[m.legs[leg].to]));
}

std::string LegEndpointError(const WebMission& m, size_t leg, const std::string& message) {
  // The server names the endpoint it refuses first.
  const size_t goal_at = message.find("goal");
  const size_t start_at = message.find("start");
  const bool goal = goal_at != std::string::npos && (start_at == std::string::npos || goal_at < start_at);
  const geo::MissionPoint& p = m.mission.points[goal ? m.legs[leg].to : m.legs[leg].from];
  return absl::StrFormat("%s at (%.7f, %.7f, %.1f m): %s", client::MissionItemName(p), p.lat_deg,
                         p.lon_deg, p.alt_m, message);
}

absl::StatusOr<std::string> WithMissionLimits(std::string_view plan_json,
                                              const v1::FlightLimits& limits) {
  Json root = Json::parse(plan_json.begin(), plan_json.end(), nullptr, false);
  if (!root.is_object() || !root.contains("riskplan") || !root["riskplan"].is_object()) {
    return absl::InvalidArgumentError("the mission .plan has no 'riskplan' section");
  }
  root["riskplan"]["limits"] = Json::parse(ToJson(limits));
  return root.dump(2) + "\n";
}

}  // namespace riskplan::web
