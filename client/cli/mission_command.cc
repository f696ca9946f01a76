// `riskplan plan --mission=FILE.plan`: a QGroundControl mission planned leg by
// leg (client/mission.h), each leg risk-aware between consecutive mission
// points with the whole mission's limits shared among them, then written back
// as a .plan (--mission_out) with the GeoJSON, KML and route .plan of the same
// route (--geojson_out, --kml_out, --plan_out).
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "client/cli/command_support.h"
#include "client/cli/commands.h"
#include "client/cli/option_requests.h"
#include "client/mission.h"
#include "client/trajectory_text.h"
#include "geo/export/qgc_mission.h"

namespace riskplan::client {
namespace {

std::string GeoPoseFlag(const v1::GeoPose& p) {
  return absl::StrFormat("wgs84:%.12f,%.12f,%.6f,%.9f", p.lat_deg(), p.lon_deg(), p.alt_m(),
                         p.heading_deg());
}

// The server names the endpoint it refuses ("start_wgs84 ...", "goal_wgs84
// ..."): the message names the mission item instead, and keeps the server's.
std::string LegError(const geo::QgcMission& mission, const MissionLeg& leg,
                     const grpc::Status& status) {
  const std::string& m = status.error_message();
  const bool goal = m.find("goal") != std::string::npos &&
                    (m.find("start") == std::string::npos || m.find("goal") < m.find("start"));
  const geo::MissionPoint& point = mission.points[goal ? leg.to : leg.from];
  return absl::StrFormat("%s at (%.7f, %.7f, %.1f m): %s", MissionItemName(point), point.lat_deg,
                         point.lon_deg, point.alt_m, m);
}

bool AnyLimit(const v1::FlightLimits& l) {
  return l.max_flight_time_s() > 0 || l.max_length_m() > 0 || l.max_risk() > 0 ||
         l.max_risk_per_flight_hour() > 0 || l.objective() == v1::MIN_TIME;
}

void Margin(const char* name, double limit, double value, const char* unit) {
  if (limit <= 0.0) return;
  std::printf("limit %s = %g%s: %.6g%s, margin %.6g%s (%.1f %%)\n", name, limit, unit, value, unit,
              limit - value, unit, 100.0 * (limit - value) / limit);
}

}  // namespace

int RunMission(const CliOptions& o, RiskplanClient& client) {
  std::ifstream in(o.mission);
  if (!in) return Usage(absl::StrFormat("--mission=%s: cannot read the file", o.mission));
  std::stringstream text;
  text << in.rdbuf();
  absl::StatusOr<geo::QgcMission> mission = geo::ParseQgcPlan(text.str());
  if (!mission.ok()) {
    return Usage(absl::StrFormat("--mission=%s: %s", o.mission, mission.status().message()));
  }
  const std::vector<double> headings = MissionHeadings(*mission);
  const std::vector<MissionLeg> legs = MissionLegs(*mission, headings);

  // The base request of every leg: the plan flags, with the first leg's ends.
  CliOptions leg_options = o;
  leg_options.start = GeoPoseFlag(legs.front().start);
  leg_options.goal = GeoPoseFlag(legs.front().goal);
  absl::StatusOr<v1::PlanRequest> base = PlanRequestFromOptions(leg_options);
  if (!base.ok()) return Usage(std::string(base.status().message()));
  const v1::FlightLimits whole = base->limits();
  base->clear_limits();
  absl::StatusOr<ExportFiles> exports = ExportsFromOptions(o);
  if (!exports.ok()) return Usage(std::string(exports.status().message()));
  if (absl::Status s = CheckMapHasGeo(client, o.map); !s.ok()) return ExportError(s);

  std::printf("mission %s on %s: %d points, %d legs, %s, budget %d ms per leg, seed %d\n",
              o.mission.c_str(), o.map.c_str(), static_cast<int>(mission->points.size()),
              static_cast<int>(legs.size()), v1::Algorithm_Name(base->algorithm()).c_str(),
              static_cast<int>(o.budget_ms), static_cast<int>(o.seed));
  for (size_t k = 0; k < mission->points.size(); ++k) {
    const geo::MissionPoint& p = mission->points[k];
    std::printf("  point %d: %s at (%.7f, %.7f, %.1f m AMSL), heading %.1f deg%s\n",
                static_cast<int>(k), MissionItemName(p).c_str(), p.lat_deg, p.lon_deg, p.alt_m,
                headings[k], p.heading_deg.has_value() ? "" : " (chosen)");
  }
  std::fflush(stdout);

  // Every leg's ends checked by the server before any leg is planned (one
  // iteration each), so that a point off the map fails at once, named.
  for (const MissionLeg& leg : legs) {
    v1::PlanRequest check = *base;
    *check.mutable_start_wgs84() = leg.start;
    *check.mutable_goal_wgs84() = leg.goal;
    check.mutable_budget()->set_time_ms(0);
    check.mutable_budget()->set_iterations(1);
    check.set_min_update_interval_ms(0);
    grpc::Status s = client.Plan(
        check, [](const v1::PlanUpdate&) { return true; }, TimeoutOr(o, absl::Seconds(60)));
    if (s.ok()) continue;
    if (s.error_code() == grpc::StatusCode::INVALID_ARGUMENT) {
      return Usage(LegError(*mission, leg, s));
    }
    return RpcError(o, "PlanTrajectory", s);
  }

  MissionUsed used;
  std::vector<v1::Pose> waypoints;  // the whole mission's, local
  std::vector<std::vector<v1::Pose>> leg_waypoints;
  for (size_t i = 0; i < legs.size(); ++i) {
    const MissionLeg& leg = legs[i];
    v1::PlanRequest request = *base;
    *request.mutable_start_wgs84() = leg.start;
    *request.mutable_goal_wgs84() = leg.goal;
    if (AnyLimit(whole)) *request.mutable_limits() = LegLimits(whole, used, *mission, legs, i);
    v1::PlanUpdate final_update;
    grpc::Status s = client.Plan(
        request,
        [&](const v1::PlanUpdate& u) {
          if (u.final()) final_update = u;
          return true;
        },
        TimeoutOr(o, absl::InfiniteDuration()));
    const std::string name = absl::StrFormat(
        "leg %d (%s -> %s)", static_cast<int>(i + 1), MissionItemName(mission->points[leg.from]),
        MissionItemName(mission->points[leg.to]));
    if (!s.ok()) {
      std::fprintf(stderr, "riskplan: %s: ", name.c_str());
      return RpcError(o, "PlanTrajectory", s);
    }
    if (!final_update.has_trajectory()) {
      const std::string why = final_update.limits().note().empty()
                                  ? std::string("no admissible trajectory was found")
                                  : final_update.limits().note();
      std::printf("%s failed: %s (%s)\n", name.c_str(), why.c_str(),
                  v1::EndReason_Name(final_update.end_reason()).c_str());
      std::printf("the mission is not planned: %s cannot be flown within the limits left to it\n",
                  name.c_str());
      return 3;
    }
    const v1::Trajectory& t = final_update.trajectory();
    std::printf("%s: risk %.6g, length %.1f m, flight time %.1f s, %d waypoints\n", name.c_str(),
                t.risk(), t.length_m(), t.flight_time_s(), t.waypoints_size());
    std::fflush(stdout);
    used.flight_time_s += t.flight_time_s();
    used.length_m += t.length_m();
    used.risk += t.risk();
    leg_waypoints.emplace_back(t.waypoints().begin(), t.waypoints().end());
    for (int k = waypoints.empty() ? 0 : 1; k < t.waypoints_size(); ++k) {
      waypoints.push_back(t.waypoints(k));
    }
  }

  // The whole mission evaluated at once: its exact totals.
  v1::EvaluateRiskRequest eval;
  eval.set_map(o.map);
  *eval.mutable_model_params() = base->model_params();
  if (base->has_wind()) *eval.mutable_wind() = base->wind();
  if (base->has_wind_wgs84()) *eval.mutable_wind_wgs84() = base->wind_wgs84();
  eval.mutable_waypoints()->mutable_poses()->Assign(waypoints.begin(), waypoints.end());
  v1::EvaluateRiskResponse total;
  if (grpc::Status s = client.EvaluateRisk(eval, &total, TimeoutOr(o, absl::Seconds(30)));
      !s.ok()) {
    return RpcError(o, "EvaluateRisk", s);
  }
  std::printf(
      "mission: risk %.9g expected casualties per flight, length %.1f m, flight time %.1f s, "
      "%d waypoints, %s\n",
      total.risk(), total.length_m(), total.flight_time_s(), static_cast<int>(waypoints.size()),
      total.admissible() ? "admissible" : "NOT admissible");
  std::printf("%s\n", TargetLevelOfSafetyText(total.risk_per_flight_hour(), total.flight_time_s(),
                                              total.airspeed_mps(), o.target_level_of_safety)
                          .c_str());
  Margin("max_flight_time_s", whole.max_flight_time_s(), total.flight_time_s(), " s");
  Margin("max_length_m", whole.max_length_m(), total.length_m(), " m");
  Margin("max_risk", whole.max_risk(), total.risk(), "");
  Margin("max_risk_per_flight_hour", whole.max_risk_per_flight_hour(),
         total.risk_per_flight_hour(), "");

  if (!o.trajectory_out.empty()) {
    std::ofstream out(o.trajectory_out);
    out << WaypointsToJson(google::protobuf::RepeatedPtrField<v1::Pose>(waypoints.begin(),
                                                                         waypoints.end()));
    out.close();
    if (!out) return Usage(absl::StrFormat("cannot write --trajectory_out=%s", o.trajectory_out));
    std::printf("trajectory: %s\n", o.trajectory_out.c_str());
  }
  if (o.mission_out.empty() && !exports->any()) return 0;

  // Each leg's path sampled by the server in both frames, joined.
  std::vector<geo::ExportTrajectory> paths;
  const std::string description =
      absl::StrFormat("riskplan plan --mission on %s: %s, seed %d, %d legs", o.map,
                      v1::Algorithm_Name(base->algorithm()), o.seed, legs.size());
  for (size_t i = 0; i < leg_waypoints.size(); ++i) {
    v1::EvaluateRiskRequest leg_eval = eval;
    leg_eval.mutable_waypoints()->mutable_poses()->Assign(leg_waypoints[i].begin(),
                                                          leg_waypoints[i].end());
    leg_eval.set_path_spacing_m(exports->spacing_m);
    v1::EvaluateRiskResponse path;
    if (grpc::Status s = client.EvaluateRisk(leg_eval, &path, TimeoutOr(o, absl::Seconds(30)));
        !s.ok()) {
      return RpcError(o, "EvaluateRisk", s);
    }
    absl::StatusOr<geo::ExportTrajectory> t =
        ExportTrajectoryOf(path, o.map, description, exports->spacing_m);
    if (!t.ok()) return ExportError(t.status());
    paths.push_back(*std::move(t));
  }
  absl::StatusOr<JoinedRoute> joined = JoinLegs(paths);
  if (!joined.ok()) return ExportError(joined.status());
  geo::ExportTrajectory& route = joined->route;
  route.risk = total.risk();
  route.length_m = total.length_m();
  route.flight_time_s = total.flight_time_s();
  route.risk_per_flight_hour = total.risk_per_flight_hour();
  if (!o.mission_out.empty()) {
    absl::StatusOr<std::string> plan =
        geo::QgcMissionPlanJson(*mission, route, joined->leg_end_sample);
    if (!plan.ok()) return ExportError(plan.status());
    if (absl::Status s = geo::WriteTextFileAtomically(*plan, o.mission_out); !s.ok()) {
      return ExportError(s);
    }
    std::printf("mission: %s\n", o.mission_out.c_str());
  }
  if (exports->any()) {
    if (absl::Status s = WriteExports(*exports, route); !s.ok()) return ExportError(s);
  }
  return 0;
}

}  // namespace riskplan::client
