#include "client/cli/commands.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <tuple>
#include <utility>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/str_format.h"
#include "client/cli/fleet_file.h"
#include "client/load/load_generator.h"
#include "client/picture/picture.h"
#include "client/trajectory_text.h"
#include "google/protobuf/util/json_util.h"

// The commands behind `riskplan`. Each builds its request from CliOptions
// and checks the options before the first call, so a mistyped flag costs no
// server time and exits 2, while a failed call exits 1 (the codes of
// commands.h): a script can tell its own mistakes from the server's.
// Validation is left to the server wherever it knows more (ranges, planner
// parameter names, admissibility), so a newer server needs no newer client.

namespace riskplan::client {
namespace {

int Usage(const std::string& message) {
  std::fprintf(stderr, "riskplan: %s\n", message.c_str());
  return 2;
}

absl::Status InFlag(const char* flag, const absl::Status& status) {
  return absl::Status(status.code(), absl::StrFormat("%s: %s", flag, status.message()));
}

}  // namespace

// The code by name, as docs/api.md lists the codes with their meaning and
// whether a retry can help.
// A failure to connect or a refusal comes with what it most likely means
// (ExplainStatus: which side refused the handshake, a token, a role).
int RpcError(const CliOptions& o, const char* method, const grpc::Status& status) {
  std::fprintf(stderr, "riskplan: %s failed: %s: %s\n", method,
               StatusCodeName(status.error_code()).c_str(),
               ExplainStatus(status, o.connection).c_str());
  return 1;
}

namespace {

// The proto3 JSON mapping, with the proto's own field names (sample_count,
// not sampleCount) so that --json output matches the proto and the docs.
// 64-bit integers come out as strings, as the mapping requires (a double
// cannot hold them all). Printing fails only for an Any of an unknown type,
// and the API has no Any field, so the status is ignored.
std::string ToJson(const google::protobuf::Message& message) {
  std::string out;
  google::protobuf::util::JsonPrintOptions options;
  options.add_whitespace = true;
  options.preserve_proto_field_names = true;
  (void)google::protobuf::util::MessageToJsonString(message, &out, options);
  return out;
}

// --timeout_ms=0 (the default) means "the command's own deadline", which
// differs by command (riskplan_main.cc's help lists them).
absl::Duration TimeoutOr(const CliOptions& o, absl::Duration fallback) {
  return o.timeout > absl::ZeroDuration() ? o.timeout : fallback;
}

absl::StatusOr<v1::EvaluateRiskRequest> EvalRequest(const CliOptions& o) {
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

// One line for the two-tier result. A coarse-tier hit names a block of the
// coarse grid, not a map cell, so the word says which grid the indices are on.
std::string TwoTierText(const v1::TwoTierResult& t) {
  if (t.feasible()) {
    return absl::StrFormat("two-tier check: feasible (%d cells checked)",
                           static_cast<int64_t>(t.cells_checked()));
  }
  return absl::StrFormat(
      "two-tier check: NOT feasible: %s tier, %s in piece %d at (%.1f, %.1f, %.1f), %s %d, %d "
      "(%d cells checked)",
      v1::FeasibilityTier_Name(t.tier()), v1::ViolationKind_Name(t.kind()), t.segment(),
      t.position().x(), t.position().y(), t.position().z(),
      t.tier() == v1::COARSE ? "block" : "cell", t.cell_i(), t.cell_j(),
      static_cast<int64_t>(t.cells_checked()));
}

absl::StatusOr<v1::PlanRequest> PlanRequest(const CliOptions& o) {
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

std::string PoseText(const v1::Pose& p) {
  return absl::StrFormat("(%.1f, %.1f, %.1f, %.3f)", p.x(), p.y(), p.z(), p.theta());
}

std::string GeoPoseText(const v1::GeoPose& p) {
  return absl::StrFormat("(%.7f, %.7f, %.1f m, %.1f deg)", p.lat_deg(), p.lon_deg(), p.alt_m(),
                         p.heading_deg());
}

std::string StartText(const v1::PlanRequest& r) {
  return r.has_start_wgs84() ? GeoPoseText(r.start_wgs84()) : PoseText(r.start());
}

std::string GoalText(const v1::PlanRequest& r) {
  return r.has_goal_wgs84() ? GeoPoseText(r.goal_wgs84()) : PoseText(r.goal());
}

// The export options from the flags, checked before any call (with the
// target level of safety, which the same commands read).
absl::StatusOr<ExportFiles> ExportsFromOptions(const CliOptions& o) {
  if (!(o.target_level_of_safety > 0.0) || !std::isfinite(o.target_level_of_safety)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "--target_level_of_safety=%g: must be finite and > 0 (expected casualties per flight "
        "hour)",
        o.target_level_of_safety));
  }
  ExportFiles files = o.exports;
  if (absl::Status s = CheckExportFiles(o.plan_firmware, &files); !s.ok()) return s;
  return files;
}

// Exit code of a failed export: 2 when the input cannot be exported (a map
// without geo-reference), 1 when a file cannot be written.
int ExportError(const absl::Status& status) {
  std::fprintf(stderr, "riskplan: %s\n", std::string(status.message()).c_str());
  return absl::IsUnavailable(status) ? 1 : 2;
}

// Exports the evaluation of a trajectory that has a path.
int Export(const ExportFiles& files, const v1::EvaluateRiskResponse& response,
           const std::string& map, const std::string& description, bool quiet = false) {
  absl::StatusOr<geo::ExportTrajectory> trajectory =
      ExportTrajectoryOf(response, map, description, files.spacing_m);
  if (!trajectory.ok()) return ExportError(trajectory.status());
  if (absl::Status s = WriteExports(files, *trajectory, quiet); !s.ok()) return ExportError(s);
  return 0;
}

// The local start and goal of a plan request (for its picture).
absl::StatusOr<std::pair<v1::Pose, v1::Pose>> LocalEndpoints(RiskplanClient& client,
                                                             const v1::PlanRequest& request,
                                                             const v1::PlanUpdate& final_update,
                                                             absl::Duration timeout) {
  if (final_update.has_trajectory() && final_update.trajectory().waypoints_size() >= 2) {
    const auto& w = final_update.trajectory().waypoints();
    return std::pair{w[0], w[w.size() - 1]};
  }
  v1::EvaluateRiskRequest eval;
  eval.set_map(request.map());
  eval.set_path_spacing_m(100000.0);
  if (request.has_start_wgs84() && request.has_goal_wgs84()) {
    for (const v1::GeoPose* p : {&request.start_wgs84(), &request.goal_wgs84()}) {
      v1::GeoPoint3* q = eval.mutable_polyline_wgs84()->add_points();
      q->set_lat_deg(p->lat_deg());
      q->set_lon_deg(p->lon_deg());
      q->set_alt_m(p->alt_m());
    }
  } else {
    // One endpoint in each frame: only the WGS84 one needs converting; a
    // polyline from it to itself has a single path pose.
    const v1::GeoPose& p = request.has_start_wgs84() ? request.start_wgs84() : request.goal_wgs84();
    for (int k = 0; k < 2; ++k) {
      v1::GeoPoint3* q = eval.mutable_polyline_wgs84()->add_points();
      q->set_lat_deg(p.lat_deg());
      q->set_lon_deg(p.lon_deg());
      q->set_alt_m(p.alt_m());
    }
  }
  v1::EvaluateRiskResponse response;
  if (grpc::Status s = client.EvaluateRisk(eval, &response, timeout); !s.ok()) {
    return absl::UnavailableError(
        absl::StrFormat("EvaluateRisk of the endpoints failed: %s", s.error_message()));
  }
  if (response.path_size() < 1) return absl::InternalError("no path in EvaluateRisk's answer");
  const v1::Pose& first = response.path(0).pose();
  const v1::Pose& last = response.path(response.path_size() - 1).pose();
  if (request.has_start_wgs84() && request.has_goal_wgs84()) return std::pair{first, last};
  if (request.has_start_wgs84()) return std::pair{first, request.goal()};
  return std::pair{request.start(), first};
}

}  // namespace

// The map's landing sites and the picture's layers, fetched before the plan
// so that a plan cut short by the server's end can still be drawn. The layers
// are downsampled by the server to the picture's size: a full layer is 4
// bytes a map cell, far more than a picture of a few hundred pixels needs.
// Both are asked for at the same size, so they come on the same grid.
int FetchPictureLayers(const CliOptions& o, RiskplanClient& client, PictureInput* picture) {
  v1::ListMapsResponse maps;
  if (grpc::Status s = client.ListMaps(&maps); !s.ok()) return RpcError(o, "ListMaps", s);
  for (const v1::MapInfo& m : maps.maps()) {
    if (m.name() == o.map) picture->map = m;
  }
  v1::GetMapLayerRequest layer;
  layer.set_map(o.map);
  layer.set_max_side_cells(o.picture_size);
  layer.set_layer(v1::POPULATION_DENSITY);
  if (grpc::Status s = client.GetMapLayer(layer, &picture->density); !s.ok()) {
    return RpcError(o, "GetMapLayer", s);
  }
  layer.set_layer(v1::NO_FLY);
  if (grpc::Status s = client.GetMapLayer(layer, &picture->nofly); !s.ok()) {
    return RpcError(o, "GetMapLayer", s);
  }
  return 0;
}

namespace {

// --trajectory_out: the waypoints of `best`; 0, or the exit code of a
// failure.
int WriteTrajectoryOut(const CliOptions& o, const v1::Trajectory& best) {
  if (o.trajectory_out.empty()) return 0;
  std::ofstream out(o.trajectory_out);
  out << WaypointsToJson(best.waypoints());
  out.close();
  if (!out) return Usage(absl::StrFormat("cannot write --trajectory_out=%s", o.trajectory_out));
  std::printf("trajectory: %s\n", o.trajectory_out.c_str());
  return 0;
}

// --picture of `plan` (its improvements received, and with `final_update`
// its tree and end), its layers already in `picture`; 0, or 1 on failure.
// The picture's endpoints are local: a request in WGS84 takes them from the
// best trajectory (or asks the server, when there is none).
int WritePlanPicture(const CliOptions& o, RiskplanClient& client, const v1::PlanRequest& request,
                     const v1::PlanUpdate& final_update, PictureInput& picture) {
  picture.tree.assign(final_update.tree_edges().begin(), final_update.tree_edges().end());
  picture.start = request.start();
  picture.goal = request.goal();
  if (request.has_start_wgs84() || request.has_goal_wgs84()) {
    // The client has no map projection: the server's local form of the
    // endpoints is the best trajectory's ends, or, without one, the ends of
    // a two-point polyline it evaluates.
    if (absl::StatusOr<std::pair<v1::Pose, v1::Pose>> ends =
            LocalEndpoints(client, request, final_update, TimeoutOr(o, absl::Seconds(30)));
        ends.ok()) {
      picture.start = ends->first;
      picture.goal = ends->second;
    } else {
      std::fprintf(stderr, "riskplan: %s\n", std::string(ends.status().message()).c_str());
      return 1;
    }
  }
  if (absl::Status s = WritePicture(o.picture, picture); !s.ok()) {
    std::fprintf(stderr, "riskplan: %s\n", std::string(s.message()).c_str());
    return 1;
  }
  std::printf("picture: %s\n", o.picture.c_str());
  return 0;
}

// The stream broke (the server died or was restarted, the network failed,
// the deadline passed): what was received is kept, as it would have been at
// the end. Risk never increases along the stream, so the last improvement is
// the best one. Returns 1, the exit code of a failed RPC.
int KeepWhatWasReceived(const CliOptions& o, RiskplanClient& client, const v1::PlanRequest& request,
                        const grpc::Status& status, const ExportFiles& exports,
                        PictureInput& picture) {
  RpcError(o, "PlanTrajectory", status);
  const std::vector<v1::Trajectory>& improvements = picture.improvements;
  if (improvements.empty()) {
    std::fprintf(stderr, "riskplan: no improvement was received before the stream ended\n");
    return 1;
  }
  const v1::Trajectory& best = improvements.back();
  std::fprintf(stderr,
               "riskplan: received %d improvements before the stream ended; keeping the best: "
               "risk %.9g expected casualties per flight, length %.1f m, %d waypoints\n",
               static_cast<int>(improvements.size()), best.risk(), best.length_m(),
               best.waypoints_size());
  WriteTrajectoryOut(o, best);
  if (exports.any()) {
    std::fprintf(stderr,
                 "riskplan: --plan_out, --geojson_out and --kml_out are not written: the server "
                 "samples their path\n");
  }
  if (!o.picture.empty()) {
    picture.caption = absl::StrFormat(
        "%s, %s: %d improvements, best risk %.4g, length %.0f m (stream ended early: %s)", o.map,
        v1::Algorithm_Name(request.algorithm()), static_cast<int>(improvements.size()), best.risk(),
        best.length_m(), StatusCodeName(status.error_code()));
    // The best trajectory's ends are the endpoints: no call to the server.
    v1::PlanUpdate received;
    *received.mutable_trajectory() = best;
    WritePlanPicture(o, client, request, received, picture);
  }
  return 1;
}

}  // namespace

absl::StatusOr<v1::PlanRequest> PlanRequestFromOptions(const CliOptions& o) {
  return PlanRequest(o);
}

int RunMaps(const CliOptions& o, RiskplanClient& client) {
  v1::ListMapsResponse response;
  grpc::Status status = client.ListMaps(&response, TimeoutOr(o, absl::Seconds(10)));
  if (!status.ok()) return RpcError(o, "ListMaps", status);
  if (o.json) {
    std::printf("%s\n", ToJson(response).c_str());
    return 0;
  }
  for (const v1::MapInfo& m : response.maps()) {
    std::printf(
        "%s: %.0f x %.0f m (%d x %d cells of %g m), south-west corner (%g, %g), terrain %.1f to "
        "%.1f m AMSL, %d landing sites, %.1f MB\n",
        m.name().c_str(), m.width_m(), m.height_m(), m.nx(), m.ny(), m.resolution_m(), m.x0_m(),
        m.y0_m(), m.terrain_min_m(), m.terrain_max_m(), m.landing_sites_size(),
        m.memory_bytes() / 1e6);
    if (!m.provenance().empty()) std::printf("  provenance: %s\n", m.provenance().c_str());
    if (m.has_geo()) {
      std::printf("  geo-reference: local (%g, %g) m is WGS84 (%.9f, %.9f) deg%s\n",
                  m.geo().origin_x_m(), m.geo().origin_y_m(), m.geo().origin_lat_deg(),
                  m.geo().origin_lon_deg(),
                  m.geo().crs().empty() ? "" : absl::StrFormat(" (%s)", m.geo().crs()).c_str());
    }
    if (m.has_bounds_wgs84()) {
      const v1::GeoBounds& b = m.bounds_wgs84();
      std::printf("  WGS84 extent: latitudes %.7f to %.7f, longitudes %.7f to %.7f\n",
                  b.min_lat_deg(), b.max_lat_deg(), b.min_lon_deg(), b.max_lon_deg());
      if (!m.geo().proj_definition().empty()) {
        std::printf("  local frame: %s\n", m.geo().proj_definition().c_str());
      }
    }
  }
  return 0;
}

int RunEval(const CliOptions& o, RiskplanClient& client) {
  absl::StatusOr<v1::EvaluateRiskRequest> request = EvalRequest(o);
  if (!request.ok()) return Usage(std::string(request.status().message()));
  absl::StatusOr<ExportFiles> exports = ExportsFromOptions(o);
  if (!exports.ok()) return Usage(std::string(exports.status().message()));
  if (exports->any()) request->set_path_spacing_m(exports->spacing_m);
  v1::EvaluateRiskResponse r;
  grpc::Status status = client.EvaluateRisk(*request, &r, TimeoutOr(o, absl::Seconds(30)));
  if (!status.ok()) return RpcError(o, "EvaluateRisk", status);
  if (o.json) {
    std::printf("%s\n", ToJson(r).c_str());
    return exports->any() ? Export(*exports, r, o.map, "riskplan eval on " + o.map, /*quiet=*/true)
                          : 0;
  }
  // Risks with 9 significant digits: enough to tell apart the trajectories a
  // planner compares, and to check a plan's reported risk against an
  // evaluation of its waypoints; --json gives every digit.
  std::printf("risk %.9g expected casualties per flight, length %.1f m, %d samples, %s\n", r.risk(),
              r.length_m(), static_cast<int>(r.sample_count()),
              r.admissible() ? "admissible" : "NOT admissible");
  for (int i = 0; i < r.pieces_size(); ++i) {
    const v1::PieceEvaluation& p = r.pieces(i);
    std::printf("  piece %d: risk %.9g, length %.1f m, %d parts, %s\n", i, p.risk(), p.length_m(),
                p.parts(), p.admissible() ? "admissible" : "not admissible");
  }
  std::printf("%s\n", TargetLevelOfSafetyText(r.risk_per_flight_hour(), r.flight_time_s(),
                                              r.airspeed_mps(), o.target_level_of_safety)
                          .c_str());
  if (r.has_first_violation()) {
    std::printf("first violation: %s\n", r.first_violation().message().c_str());
  }
  if (r.has_two_tier()) std::printf("%s\n", TwoTierText(r.two_tier()).c_str());
  if (o.samples) {
    std::printf("%10s %10s %8s %6s %10s %5s %12s %12s %8s %8s\n", "x", "y", "z", "theta", "arc_m",
                "piece", "M", "I", "S", "p_cas");
    for (const v1::Sample& s : r.samples()) {
      std::printf("%10.1f %10.1f %8.1f %6.3f %10.1f %5d %12.5g %12.5g %8.3f %8.5f\n", s.x(), s.y(),
                  s.z(), s.theta(), s.arc_length_m(), s.piece(), s.risk(), s.impact_factor(),
                  s.expected_shelter(), s.casualty_probability());
    }
  }
  if (exports->any()) return Export(*exports, r, o.map, "riskplan eval on " + o.map);
  return 0;
}

int RunPlan(const CliOptions& o, RiskplanClient& client) {
  absl::StatusOr<v1::PlanRequest> request = PlanRequest(o);
  if (!request.ok()) return Usage(std::string(request.status().message()));
  // The picture's name is checked before planning, not after a plan of many
  // seconds that would then be lost.
  if (!o.picture.empty() && !o.picture.ends_with(".svg") && !o.picture.ends_with(".png")) {
    return Usage("--picture must name a .svg or .png file");
  }
  absl::StatusOr<ExportFiles> exports = ExportsFromOptions(o);
  if (!exports.ok()) return Usage(std::string(exports.status().message()));
  if (exports->any()) {
    if (absl::Status s = CheckMapHasGeo(client, o.map); !s.ok()) return ExportError(s);
  }
  PictureInput picture;
  if (!o.picture.empty()) {
    if (int code = FetchPictureLayers(o, client, &picture); code != 0) return code;
  }
  std::printf("plan on %s: start %s -> goal %s, %s, budget %d ms%s, seed %d\n", o.map.c_str(),
              StartText(*request).c_str(), GoalText(*request).c_str(),
              v1::Algorithm_Name(request->algorithm()).c_str(), static_cast<int>(o.budget_ms),
              o.iterations > 0 ? absl::StrFormat(" / %d iterations", o.iterations).c_str() : "",
              static_cast<int>(o.seed));
  std::printf("%5s %9s %11s %10s %14s %10s\n", "seq", "elapsed_s", "iterations", "tree_size",
              "best_risk", "length_m");
  // Flushed after every line: stdout is fully buffered when piped, and the
  // point of streaming is to see each improvement as it arrives.
  std::fflush(stdout);

  std::vector<v1::Trajectory>& improvements = picture.improvements;
  v1::PlanUpdate final_update;
  // No deadline by default: the plan's budget already bounds it on the server
  // (and --max_plan_time_ms caps every plan), so a client deadline could only
  // cut a plan short and lose its final message.
  const absl::Duration timeout =
      o.timeout > absl::ZeroDuration() ? o.timeout : absl::InfiniteDuration();
  grpc::Status status = client.Plan(
      *request,
      [&](const v1::PlanUpdate& u) {
        // Every message repeats the best trajectory so far (the final one
        // too), so a trajectory counts as an improvement only when it
        // differs from the last one kept; the picture draws each once.
        if (u.has_trajectory() &&
            (improvements.empty() ||
             u.trajectory().found_at_iteration() != improvements.back().found_at_iteration() ||
             u.trajectory().risk() != improvements.back().risk())) {
          improvements.push_back(u.trajectory());
        }
        std::printf(
            "%5d %9.3f %11d %10d %14.6g %10.1f%s\n", static_cast<int>(u.sequence()), u.elapsed_s(),
            static_cast<int>(u.iterations()), static_cast<int>(u.tree_size()),
            u.has_trajectory() ? u.trajectory().risk() : 0.0,
            u.has_trajectory() ? u.trajectory().length_m() : 0.0, u.final() ? "  (final)" : "");
        std::fflush(stdout);
        if (u.final()) final_update = u;
        return true;
      },
      timeout);
  if (!status.ok()) return KeepWhatWasReceived(o, client, *request, status, *exports, picture);

  // "found" counts every improvement of the planner, also those the server
  // never sent because a newer one replaced them (docs/api.md, "The
  // stream"); "sent" counts the distinct ones received.
  std::printf(
      "ended: %s after %.2f s, %d iterations, tree of %d nodes, %d improvements found "
      "(%d sent)\n",
      v1::EndReason_Name(final_update.end_reason()).c_str(), final_update.elapsed_s(),
      static_cast<int>(final_update.iterations()), static_cast<int>(final_update.tree_size()),
      static_cast<int>(final_update.improvements()), static_cast<int>(improvements.size()));
  if (final_update.has_trajectory()) {
    const v1::Trajectory& best = final_update.trajectory();
    std::printf("best: risk %.9g expected casualties per flight, length %.1f m, %d waypoints\n",
                best.risk(), best.length_m(), best.waypoints_size());
    std::printf("%s\n", TargetLevelOfSafetyText(
                            best.risk_per_flight_hour(), best.flight_time_s(),
                            best.flight_time_s() > 0 ? best.length_m() / best.flight_time_s() : 0,
                            o.target_level_of_safety)
                            .c_str());
    if (int code = WriteTrajectoryOut(o, best); code != 0) return code;
    if (exports->any()) {
      // The server samples the best trajectory's path in both frames: the
      // client cannot (it has no map projection), and the same waypoints
      // and parameters give exactly the plan's risk.
      v1::EvaluateRiskRequest eval;
      eval.set_map(o.map);
      eval.mutable_waypoints()->mutable_poses()->CopyFrom(best.waypoints());
      *eval.mutable_model_params() = request->model_params();
      eval.set_path_spacing_m(exports->spacing_m);
      v1::EvaluateRiskResponse path;
      if (grpc::Status s = client.EvaluateRisk(eval, &path, TimeoutOr(o, absl::Seconds(30)));
          !s.ok()) {
        return RpcError(o, "EvaluateRisk", s);
      }
      const std::string description = absl::StrFormat(
          "riskplan plan on %s: %s, seed %d, %s", o.map, v1::Algorithm_Name(request->algorithm()),
          o.seed, v1::EndReason_Name(final_update.end_reason()));
      if (int code = Export(*exports, path, o.map, description); code != 0) return code;
    }
  } else {
    std::printf("no admissible trajectory was found\n");
  }

  if (!o.picture.empty()) {
    picture.caption = absl::StrFormat(
        "%s, %s: %d improvements, best risk %.4g, length %.0f m, %d iterations (%s)", o.map,
        v1::Algorithm_Name(request->algorithm()), static_cast<int>(improvements.size()),
        final_update.trajectory().risk(), final_update.trajectory().length_m(),
        static_cast<int>(final_update.iterations()), v1::EndReason_Name(final_update.end_reason()));
    if (int code = WritePlanPicture(o, client, *request, final_update, picture); code != 0) {
      return code;
    }
  }
  // 3 tells a script that the plan ran but found nothing (NO_SOLUTION, or a
  // SHUTDOWN before the first solution), which is not an RPC failure.
  return final_update.has_trajectory() ? 0 : 3;
}

int RunLoad(const CliOptions& o, RiskplanClient& client) {
  LoadOptions load;
  if (o.rpc == "eval") {
    load.rpc = LoadRpc::kEvaluateRisk;
    absl::StatusOr<v1::EvaluateRiskRequest> request = EvalRequest(o);
    if (!request.ok()) return Usage(std::string(request.status().message()));
    load.eval_request = *request;
  } else if (o.rpc == "plan") {
    load.rpc = LoadRpc::kPlanTrajectory;
    absl::StatusOr<v1::PlanRequest> request = PlanRequest(o);
    if (!request.ok()) return Usage(std::string(request.status().message()));
    load.plan_request = *request;
  } else if (o.rpc == "fleet") {
    load.rpc = LoadRpc::kPlanFleet;
    if (o.missions.empty()) return Usage("--rpc=fleet needs --missions=FILE.json");
    absl::StatusOr<v1::FleetRequest> request = ReadMissionsFile(o.missions, o);
    if (!request.ok()) return Usage(std::string(request.status().message()));
    load.fleet_request = *request;
  } else if (o.rpc == "ping") {
    load.rpc = LoadRpc::kPing;
  } else if (o.rpc == "connect") {
    if (o.mode != "closed") return Usage("--rpc=connect runs in closed loop only");
    load.rpc = LoadRpc::kConnect;
    load.new_channel = [&o] {
      grpc::ChannelArguments own;
      own.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
      // The files were read once already (main), so this cannot fail.
      return *MakeChannel(o.server, o.connection, own);
    };
  } else {
    return Usage(absl::StrFormat("--rpc=%s: must be eval, plan, fleet, ping or connect", o.rpc));
  }
  if (o.mode != "closed" && o.mode != "open") {
    return Usage(absl::StrFormat("--mode=%s: must be closed or open", o.mode));
  }
  load.mode = o.mode == "closed" ? LoadMode::kClosed : LoadMode::kOpen;
  // Written as !(x > 0) so that NaN is refused too.
  if (o.concurrency < 1 || !(o.rate > 0) || !(o.duration_s > 0) || o.max_outstanding < 1) {
    return Usage("--concurrency, --rate, --duration_s and --max_outstanding must be > 0");
  }
  load.concurrency = o.concurrency;
  load.rate_per_s = o.rate;
  load.duration = absl::Seconds(o.duration_s);
  load.timeout = TimeoutOr(o, absl::Seconds(30));
  load.max_outstanding = o.max_outstanding;

  auto progress = [](const LoadProgress& p) {
    std::printf(
        "  t=%6.1fs sent %8d done %8d errors %6d in flight %5d | %9.1f calls/s, p50 %8.3f "
        "ms, p99 %8.3f ms\n",
        p.elapsed_s, static_cast<int>(p.sent), static_cast<int>(p.completed),
        static_cast<int>(p.errors), static_cast<int>(p.outstanding), p.interval_rps,
        p.interval_p50_s * 1e3, p.interval_p99_s * 1e3);
    std::fflush(stdout);
  };
  // The ceiling is Ping, a call that does nothing, under the same load: what
  // the transport, gRPC and the server's threads cost alone. The ratios
  // against it show how much the RPC's own work costs beyond that.
  std::optional<LoadReport> ceiling;
  if (o.ceiling && load.rpc != LoadRpc::kPing) {
    LoadOptions ping = load;
    ping.rpc = LoadRpc::kPing;
    std::printf("load: no-op ceiling (Ping), %s loop, %.1f s\n", o.mode.c_str(), o.duration_s);
    ceiling = RunLoad(client.channel(), ping, progress);
  }
  std::printf("load: %s, %s loop, %.1f s\n", LoadRpcName(load.rpc).c_str(), o.mode.c_str(),
              o.duration_s);
  LoadReport report = RunLoad(client.channel(), load, progress);
  const LoadReport* ceiling_ptr = ceiling.has_value() ? &*ceiling : nullptr;
  std::printf("\n%s", LoadReportText(report, ceiling_ptr).c_str());
  if (!o.report_json.empty()) {
    std::ofstream out(o.report_json);
    out << LoadReportJson(report, ceiling_ptr);
    if (!out) return Usage(absl::StrFormat("cannot write --report_json=%s", o.report_json));
    std::printf("report: %s\n", o.report_json.c_str());
  }
  return 0;
}

}  // namespace riskplan::client
