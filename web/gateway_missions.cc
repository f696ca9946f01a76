// The gateway's QGroundControl mission routes (docs/web.md, "Missions").
#include <httplib.h>

#include <algorithm>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "client/exports.h"
#include "client/mission.h"
#include "geo/export/qgc_mission.h"
#include "nlohmann/json.hpp"
#include "web/gateway.h"
#include "web/gateway_internal.h"
#include "web/mission_file.h"
#include "web/proto_json.h"

namespace riskplan::web {

using namespace gateway_internal;  // NOLINT: the route files' shared helpers
using Json = nlohmann::json;

// QGroundControl missions (docs/web.md, "Missions"). The .plan is read by
// geo/export's ParseQgcPlan and cut into legs by client/mission.h, as
// `riskplan plan --mission` does; the page never parses a .plan itself.

namespace {

// The most legs a mission planned through the gateway may have: each is a
// plan of the page's budget, one after the other.
constexpr size_t kMaxMissionLegs = 100;

// The JSON object of a mission route's body, its keys checked against
// `known` ("unknown field 'x'" naming the route's fields).
absl::StatusOr<Json> MissionBody(const std::string& body, const std::vector<std::string>& known) {
  Json root = Json::parse(body, nullptr, /*allow_exceptions=*/false);
  if (!root.is_object()) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "the body must be a JSON object with the fields %s", absl::StrJoin(known, ", ")));
  }
  for (auto it = root.begin(); it != root.end(); ++it) {
    if (std::find(known.begin(), known.end(), it.key()) == known.end()) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "unknown field '%s'; the body has the fields %s", it.key(), absl::StrJoin(known, ", ")));
    }
  }
  if (!root.contains("plan") || !root["plan"].is_string()) {
    return absl::InvalidArgumentError("'plan' is required: the text of the QGroundControl .plan");
  }
  return root;
}

absl::StatusOr<std::shared_ptr<const WebMission>> ReadMissionOf(const std::string& text) {
  absl::StatusOr<WebMission> mission = ReadMissionFile(text);
  if (!mission.ok()) return mission.status();
  if (mission->legs.size() > kMaxMissionLegs) {
    return absl::InvalidArgumentError(absl::StrFormat(
        ".plan: the mission has %d legs; this gateway plans missions of at most %d legs",
        mission->legs.size(), kMaxMissionLegs));
  }
  return std::make_shared<const WebMission>(*std::move(mission));
}

}  // namespace

// POST /api/mission/parse, body: the .plan's text. The mission for the form.
void Gateway::PostMissionParse(const httplib::Request& req, httplib::Response& res) {
  absl::StatusOr<std::shared_ptr<const WebMission>> mission = ReadMissionOf(req.body);
  if (!mission.ok()) return SendGatewayError(res, mission.status());
  SendJsonTo(req, res, MissionJson(**mission));
}

absl::Status Gateway::CheckMissionMap(const std::string& name) {
  absl::StatusOr<std::shared_ptr<const v1::ListMapsResponse>> maps = Maps(false);
  if (!maps.ok()) return absl::OkStatus();  // the server will say what is wrong
  const v1::MapInfo* map = FindMap(**maps, name);
  if (map == nullptr) {
    maps = Maps(true);
    if (!maps.ok()) return absl::OkStatus();
    map = FindMap(**maps, name);
  }
  if (map == nullptr) return absl::OkStatus();  // CheckPlan names the maps there are
  if (!map->has_bounds_wgs84()) {
    return absl::FailedPreconditionError(absl::StrFormat(
        "map '%s' has no geo-reference: a QGroundControl mission is in WGS84; choose a "
        "geo-referenced map",
        name));
  }
  return absl::OkStatus();
}

// POST /api/mission/plans, body: {"plan": the .plan's text, "request": a
// PlanRequest without start and goal (map, algorithm, budget per leg, seed,
// wind, limits of the whole mission)}. 201 {id, events, legs}.
void Gateway::PostMissionPlan(const httplib::Request& req, httplib::Response& res) {
  absl::StatusOr<Json> body = MissionBody(req.body, {"plan", "request"});
  if (!body.ok()) return SendGatewayError(res, body.status());
  v1::PlanRequest request;
  if (absl::Status s = JsonMessageField(*body, "request", &request); !s.ok()) {
    return SendGatewayError(res, s);
  }
  if (request.start_frame_case() != v1::PlanRequest::START_FRAME_NOT_SET ||
      request.goal_frame_case() != v1::PlanRequest::GOAL_FRAME_NOT_SET) {
    return SendGatewayError(res, absl::InvalidArgumentError(
                                     "request: start and goal are the mission's points; leave "
                                     "them out"));
  }
  absl::StatusOr<std::shared_ptr<const WebMission>> mission =
      ReadMissionOf((*body)["plan"].get<std::string>());
  if (!mission.ok()) return SendGatewayError(res, mission.status());
  request.set_include_tree(false);
  if (absl::Status s = CheckMissionMap(request.map()); !s.ok()) return SendGatewayError(res, s);
  // What CheckPlan refuses of a plan, for each leg: a point outside the map
  // names its mission item.
  for (size_t i = 0; i < (*mission)->legs.size(); ++i) {
    v1::PlanRequest leg = request;
    *leg.mutable_start_wgs84() = (*mission)->legs[i].start;
    *leg.mutable_goal_wgs84() = (*mission)->legs[i].goal;
    absl::Status s = CheckPlan(leg);
    if (s.ok()) continue;
    if (absl::StrContains(s.message(), "_wgs84 (lat, lon)")) {
      s = absl::Status(s.code(), LegEndpointError(**mission, i, std::string(s.message())));
    }
    return SendGatewayError(res, s);
  }
  auto plan = std::make_shared<MissionPlan>();
  plan->mission = *mission;
  plan->whole = request.limits();
  request.clear_limits();
  auto session = plans_.Start(std::move(request), std::move(plan));
  if (!session.ok()) return SendGatewayError(res, session.status());
  const std::string& id = (*session)->id();
  SendJson(res,
           Json{{"id", id},
                {"events", absl::StrCat("/api/plans/", id, "/events")},
                {"legs", (*mission)->legs.size()}}
               .dump(),
           201);
}

// POST /api/mission/export, body: {"plan": the .plan's text, "request": an
// EvaluateRiskRequest of the whole mission's waypoints (map, model, wind),
// "leg_ends": the index of each leg's last waypoint (the final event's
// mission.leg_ends), "limits": the mission's FlightLimits (optional, kept in
// the file's "riskplan" section)}. The planned mission as a .plan.
void Gateway::PostMissionExport(const httplib::Request& req, httplib::Response& res) {
  absl::StatusOr<Json> body = MissionBody(req.body, {"plan", "request", "leg_ends", "limits"});
  if (!body.ok()) return SendGatewayError(res, body.status());
  v1::EvaluateRiskRequest request;
  v1::FlightLimits limits;
  if (absl::Status s = JsonMessageField(*body, "request", &request); !s.ok()) {
    return SendGatewayError(res, s);
  }
  if (absl::Status s = JsonMessageField(*body, "limits", &limits); !s.ok()) {
    return SendGatewayError(res, s);
  }
  absl::StatusOr<std::shared_ptr<const WebMission>> mission =
      ReadMissionOf((*body)["plan"].get<std::string>());
  if (!mission.ok()) return SendGatewayError(res, mission.status());
  const WebMission& m = **mission;
  const int poses = request.waypoints().poses_size();
  if (request.trajectory_case() != v1::EvaluateRiskRequest::kWaypoints || poses < 2) {
    return SendGatewayError(res, absl::InvalidArgumentError(
                                     "request.waypoints: the planned mission's waypoints (at "
                                     "least 2) are required"));
  }
  // The legs' ends: one per leg, increasing, the last the last waypoint.
  std::vector<int> ends;
  const Json& leg_ends = body->contains("leg_ends") ? (*body)["leg_ends"] : Json();
  bool good = leg_ends.is_array() && leg_ends.size() == m.legs.size();
  for (size_t i = 0; good && i < leg_ends.size(); ++i) {
    good = leg_ends[i].is_number_integer();
    if (good) ends.push_back(leg_ends[i].get<int>());
    good = good && ends.back() > (i == 0 ? 0 : ends[i - 1]) && ends.back() < poses;
  }
  if (!good || ends.back() != poses - 1) {
    return SendGatewayError(
        res, absl::InvalidArgumentError(absl::StrFormat(
                 "leg_ends must give the index of each leg's last waypoint: %d increasing "
                 "integers in (0, %d], the last %d (the mission has %d legs and %d waypoints)",
                 m.legs.size(), poses - 1, poses - 1, m.legs.size(), poses)));
  }
  constexpr double kSpacingM = 25.0;
  const std::string description = absl::StrFormat(
      "riskplan-web mission on %s: %d legs", request.map(), m.legs.size());
  std::vector<geo::ExportTrajectory> paths;
  for (size_t i = 0; i < ends.size(); ++i) {
    v1::EvaluateRiskRequest leg = request;
    const int from = i == 0 ? 0 : ends[i - 1];
    leg.mutable_waypoints()->mutable_poses()->Clear();
    for (int k = from; k <= ends[i]; ++k) {
      *leg.mutable_waypoints()->add_poses() = request.waypoints().poses(k);
    }
    leg.set_path_spacing_m(kSpacingM);
    leg.set_include_samples(false);
    v1::EvaluateRiskResponse path;
    const grpc::Status status = client_.EvaluateRisk(leg, &path, options_.rpc_timeout);
    if (!status.ok()) return SendServerError(res, status);
    auto t = client::ExportTrajectoryOf(path, request.map(), description, kSpacingM);
    if (!t.ok()) return SendGatewayError(res, t.status());
    paths.push_back(*std::move(t));
  }
  absl::StatusOr<client::JoinedRoute> joined = client::JoinLegs(paths);
  if (!joined.ok()) return SendGatewayError(res, joined.status());
  v1::EvaluateRiskRequest whole = request;
  whole.set_include_samples(false);
  whole.set_path_spacing_m(0);
  v1::EvaluateRiskResponse total;
  if (const grpc::Status status = client_.EvaluateRisk(whole, &total, options_.rpc_timeout);
      !status.ok()) {
    return SendServerError(res, status);
  }
  geo::ExportTrajectory& route = joined->route;
  route.risk = total.risk();
  route.length_m = total.length_m();
  route.flight_time_s = total.flight_time_s();
  route.risk_per_flight_hour = total.risk_per_flight_hour();
  absl::StatusOr<std::string> text =
      geo::QgcMissionPlanJson(m.mission, route, joined->leg_end_sample);
  if (!text.ok()) return SendGatewayError(res, text.status());
  if (body->contains("limits")) {
    text = WithMissionLimits(*text, limits);
    if (!text.ok()) return SendGatewayError(res, text.status());
  }
  res.set_header("Content-Disposition",
                 absl::StrFormat("attachment; filename=\"riskplan-mission-%s.plan\"",
                                 request.map()));
  res.set_content(std::move(*text), "application/json");
}

}  // namespace riskplan::web
