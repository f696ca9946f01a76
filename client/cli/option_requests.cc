#include "client/cli/option_requests.h"

#include <map>
#include <string>
#include <string_view>
#include <tuple>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/str_format.h"
#include "client/trajectory_text.h"

namespace riskplan::client {
namespace {

// `status` with the flag it is about in front of its message.
absl::Status InFlag(const char* flag, const absl::Status& status) {
  return absl::Status(status.code(), absl::StrFormat("%s: %s", flag, status.message()));
}

// --max_flight_time_s, --max_length_m, --max_risk, --max_risk_per_flight_hour,
// --objective and --pareto into the request's limits (unset when all are at
// their defaults). The server checks the values (finite, >= 0).
absl::Status SetLimits(const CliOptions& o, v1::PlanRequest* request) {
  v1::Objective objective = v1::OBJECTIVE_UNSPECIFIED;
  if (!v1::Objective_Parse(absl::AsciiStrToUpper(o.objective), &objective) ||
      objective == v1::OBJECTIVE_UNSPECIFIED) {
    return absl::InvalidArgumentError(
        absl::StrFormat("--objective=%s: unknown; known: MIN_RISK, MIN_TIME", o.objective));
  }
  if (o.max_flight_time_s == 0.0 && o.max_length_m == 0.0 && o.max_risk == 0.0 &&
      o.max_risk_per_flight_hour == 0.0 && objective == v1::MIN_RISK && !o.pareto) {
    return absl::OkStatus();
  }
  v1::FlightLimits* limits = request->mutable_limits();
  limits->set_max_flight_time_s(o.max_flight_time_s);
  limits->set_max_length_m(o.max_length_m);
  limits->set_max_risk(o.max_risk);
  limits->set_max_risk_per_flight_hour(o.max_risk_per_flight_hour);
  limits->set_objective(objective);
  limits->set_pareto(o.pareto);
  return absl::OkStatus();
}

// --wind into the request's wind or wind_wgs84 (nothing when empty).
template <typename Request>
absl::Status SetWind(const std::string& text, Request* request) {
  if (text.empty()) return absl::OkStatus();
  v1::Wind wind;
  v1::GeoWind wind_wgs84;
  bool is_wgs84 = false;
  if (absl::Status s = ParseWind(text, "--wind", &wind, &wind_wgs84, &is_wgs84); !s.ok()) return s;
  if (is_wgs84) {
    *request->mutable_wind_wgs84() = wind_wgs84;
  } else {
    *request->mutable_wind() = wind;
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<v1::EvaluateRiskRequest> EvalRequestFromOptions(const CliOptions& o) {
  v1::EvaluateRiskRequest request;
  request.set_map(o.map);
  request.set_include_samples(o.samples);
  // Two trajectories given is an error rather than one winning, so that a
  // flag left over in a script cannot silently choose what is evaluated.
  const int given = !o.waypoints.empty() + !o.polyline.empty() + !o.trajectory_file.empty();
  if (given != 1) {
    return absl::InvalidArgumentError(
        "give exactly one of --waypoints, --polyline and --trajectory_file");
  }
  std::string_view rest;
  if (!o.waypoints.empty() && HasWgs84Prefix(o.waypoints, &rest)) {
    absl::StatusOr<v1::GeoWaypoints> w = ParseGeoWaypoints(rest);
    if (!w.ok()) return w.status();
    *request.mutable_waypoints_wgs84() = *w;
  } else if (!o.waypoints.empty()) {
    absl::StatusOr<v1::Waypoints> w = ParseWaypoints(o.waypoints);
    if (!w.ok()) return w.status();
    *request.mutable_waypoints() = *w;
  } else if (!o.polyline.empty() && HasWgs84Prefix(o.polyline, &rest)) {
    absl::StatusOr<v1::GeoPolyline> p = ParseGeoPolyline(rest);
    if (!p.ok()) return p.status();
    *request.mutable_polyline_wgs84() = *p;
  } else if (!o.polyline.empty()) {
    absl::StatusOr<v1::Polyline> p = ParsePolyline(o.polyline);
    if (!p.ok()) return p.status();
    *request.mutable_polyline() = *p;
  } else if (absl::Status s = ReadTrajectoryFile(o.trajectory_file, &request); !s.ok()) {
    return s;
  }
  if (absl::Status s = ParseModelParameters(o.params, request.mutable_model_params()); !s.ok()) {
    return s;
  }
  if (absl::Status s = SetWind(o.wind, &request); !s.ok()) return s;
  if (o.two_tier) {
    v1::TwoTierOptions* two_tier = request.mutable_two_tier();
    two_tier->set_enabled(true);
    // Names as in the proto, in any case. UNSPECIFIED parses but is not a
    // rule one can ask for by name (the server reads it as FLIGHT_BAND).
    v1::CollisionRule rule = v1::COLLISION_RULE_UNSPECIFIED;
    if (!v1::CollisionRule_Parse(absl::AsciiStrToUpper(o.two_tier_rule), &rule) ||
        rule == v1::COLLISION_RULE_UNSPECIFIED) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "--two_tier_rule=%s: unknown; known: FLIGHT_BAND, TERRAIN_ONLY", o.two_tier_rule));
    }
    two_tier->set_rule(rule);
    // -1 leaves a field unset, so that the server applies its default: for
    // these optional fields an explicit 0 means something else (no detailed
    // pieces; an invalid block size), and the defaults live in one place.
    if (o.two_tier_detailed_segments != -1) {
      two_tier->set_detailed_segments(o.two_tier_detailed_segments);
    }
    if (o.two_tier_block_cells != -1) two_tier->set_block_cells(o.two_tier_block_cells);
    two_tier->set_bresenham(o.two_tier_bresenham);
  }
  return request;
}

absl::StatusOr<v1::PlanRequest> PlanRequestFromOptions(const CliOptions& o) {
  v1::PlanRequest request;
  request.set_map(o.map);
  // Checked here so that the message names the flags (the server could only
  // say that the request has no start).
  if (o.start.empty() || o.goal.empty()) {
    return absl::InvalidArgumentError(
        "--start and --goal are required ('x,y,z,theta' or 'wgs84:lat,lon,alt,heading_deg')");
  }
  // Each endpoint in its own frame: the request keeps them apart (start or
  // start_wgs84), so a WGS84 start may meet a local goal.
  for (auto [text, local, wgs84, flag] :
       {std::tuple{&o.start, &v1::PlanRequest::mutable_start, &v1::PlanRequest::mutable_start_wgs84,
                   "--start"},
        std::tuple{&o.goal, &v1::PlanRequest::mutable_goal, &v1::PlanRequest::mutable_goal_wgs84,
                   "--goal"}}) {
    std::string_view rest;
    if (HasWgs84Prefix(*text, &rest)) {
      absl::StatusOr<v1::GeoPose> pose = ParseGeoPose(rest);
      if (!pose.ok()) return InFlag(flag, pose.status());
      *(request.*wgs84)() = *pose;
    } else {
      absl::StatusOr<v1::Pose> pose = ParsePose(*text);
      if (!pose.ok()) return InFlag(flag, pose.status());
      *(request.*local)() = *pose;
    }
  }
  // Enum names in any case (--algorithm=rrt), parsed by the proto so that a
  // new algorithm needs no change here.
  v1::Algorithm algorithm = v1::ALGORITHM_UNSPECIFIED;
  if (!v1::Algorithm_Parse(absl::AsciiStrToUpper(o.algorithm), &algorithm)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "--algorithm=%s: unknown; known: RISK_RRT_STAR, RRT, GENETIC, HARMONIC", o.algorithm));
  }
  request.set_algorithm(algorithm);
  request.mutable_budget()->set_time_ms(o.budget_ms);
  request.mutable_budget()->set_iterations(o.iterations);
  request.set_seed(o.seed);
  request.set_min_update_interval_ms(o.min_update_interval_ms);
  request.set_display_step_m(o.display_step_m);
  request.set_include_tree(o.tree);
  // Planner parameters are passed by name and checked by the server, which
  // knows each planner's parameters and ranges (`riskplan-server --help`).
  absl::StatusOr<std::map<std::string, double>> planner_params = ParseNameValues(o.planner_params);
  if (!planner_params.ok()) return planner_params.status();
  request.mutable_planner_params()->insert(planner_params->begin(), planner_params->end());
  if (absl::Status s = ParseModelParameters(o.params, request.mutable_model_params()); !s.ok()) {
    return s;
  }
  if (absl::Status s = SetWind(o.wind, &request); !s.ok()) return s;
  if (absl::Status s = SetLimits(o, &request); !s.ok()) return s;
  std::string_view rest;
  if (HasWgs84Prefix(o.obstacles, &rest)) {
    absl::StatusOr<std::vector<v1::GeoPoint2>> obstacles = ParseGeoPoints2(rest);
    if (!obstacles.ok()) return obstacles.status();
    request.mutable_obstacle_points_wgs84()->Assign(obstacles->begin(), obstacles->end());
  } else {
    absl::StatusOr<std::vector<v1::Point2>> obstacles = ParsePoints2(o.obstacles);
    if (!obstacles.ok()) return obstacles.status();
    request.mutable_obstacle_points()->Assign(obstacles->begin(), obstacles->end());
  }
  return request;
}

}  // namespace riskplan::client
