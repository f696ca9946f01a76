// `riskplan plan`: one PlanTrajectory call, its improvements as the stream
// runs, the best trajectory, and the files made of it (--trajectory_out,
// --picture, the ground-station and GIS exports). A stream that breaks still
// leaves what it delivered.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_format.h"
#include "client/cli/command_support.h"
#include "client/cli/commands.h"
#include "client/cli/option_requests.h"
#include "client/picture/picture.h"
#include "client/trajectory_text.h"

namespace riskplan::client {
namespace {

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
  picture.wind = final_update.wind();
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

// What `riskplan plan` has checked and fetched before it plans.
struct PlanSetup {
  v1::PlanRequest request;
  ExportFiles exports;
  PictureInput picture;  // the layers, with --picture
};

// Builds the request and checks every file to be written before the plan
// (a map without geo-reference cannot be exported), then fetches the
// picture's layers; 0, or the exit code of what failed (printed).
int PreparePlan(const CliOptions& o, RiskplanClient& client, PlanSetup* setup) {
  absl::StatusOr<v1::PlanRequest> request = PlanRequestFromOptions(o);
  if (!request.ok()) return Usage(std::string(request.status().message()));
  setup->request = *std::move(request);
  if (absl::Status s = CheckPictureName(o); !s.ok()) return Usage(std::string(s.message()));
  absl::StatusOr<ExportFiles> exports = ExportsFromOptions(o);
  if (!exports.ok()) return Usage(std::string(exports.status().message()));
  setup->exports = *std::move(exports);
  if (setup->exports.any()) {
    if (absl::Status s = CheckMapHasGeo(client, o.map); !s.ok()) return ExportError(s);
  }
  if (!o.picture.empty()) {
    if (int code = FetchPictureLayers(o, client, &setup->picture); code != 0) return code;
  }
  return 0;
}

void PrintPlanHeader(const CliOptions& o, const v1::PlanRequest& request) {
  std::printf("plan on %s: start %s -> goal %s, %s, budget %d ms%s, seed %d\n", o.map.c_str(),
              StartText(request).c_str(), GoalText(request).c_str(),
              v1::Algorithm_Name(request.algorithm()).c_str(), static_cast<int>(o.budget_ms),
              o.iterations > 0 ? absl::StrFormat(" / %d iterations", o.iterations).c_str() : "",
              static_cast<int>(o.seed));
  std::printf("%5s %9s %11s %10s %14s %10s\n", "seq", "elapsed_s", "iterations", "tree_size",
              "best_risk", "length_m");
  // Flushed after every line: stdout is fully buffered when piped, and the
  // point of streaming is to see each improvement as it arrives.
  std::fflush(stdout);
}

// Runs the plan, printing a line for every update as it arrives. Every
// distinct trajectory received is added to `improvements`, and the final
// message kept in `final_update`.
grpc::Status StreamPlan(const CliOptions& o, RiskplanClient& client, const v1::PlanRequest& request,
                        std::vector<v1::Trajectory>* improvements, v1::PlanUpdate* final_update) {
  // No deadline by default: the plan's budget already bounds it on the server
  // (and --max_plan_time_ms caps every plan), so a client deadline could only
  // cut a plan short and lose its final message.
  return client.Plan(
      request,
      [&](const v1::PlanUpdate& u) {
        // Every message repeats the best trajectory so far (the final one
        // too), so a trajectory counts as an improvement only when it
        // differs from the last one kept; the picture draws each once.
        if (u.has_trajectory() &&
            (improvements->empty() ||
             u.trajectory().found_at_iteration() != improvements->back().found_at_iteration() ||
             u.trajectory().risk() != improvements->back().risk())) {
          improvements->push_back(u.trajectory());
        }
        std::printf(
            "%5d %9.3f %11d %10d %14.6g %10.1f%s\n", static_cast<int>(u.sequence()), u.elapsed_s(),
            static_cast<int>(u.iterations()), static_cast<int>(u.tree_size()),
            u.has_trajectory() ? u.trajectory().risk() : 0.0,
            u.has_trajectory() ? u.trajectory().length_m() : 0.0, u.final() ? "  (final)" : "");
        std::fflush(stdout);
        if (u.final()) *final_update = u;
        return true;
      },
      TimeoutOr(o, absl::InfiniteDuration()));
}

// How the plan ended, and its best trajectory if it has one.
void PrintPlanEnd(const CliOptions& o, const v1::PlanRequest& request,
                  const v1::PlanUpdate& final_update, size_t received) {
  // "found" counts every improvement of the planner, also those the server
  // never sent because a newer one replaced them (docs/api.md, "The
  // stream"); "sent" counts the distinct ones received.
  std::printf(
      "ended: %s after %.2f s, %d iterations, tree of %d nodes, %d improvements found "
      "(%d sent)\n",
      v1::EndReason_Name(final_update.end_reason()).c_str(), final_update.elapsed_s(),
      static_cast<int>(final_update.iterations()), static_cast<int>(final_update.tree_size()),
      static_cast<int>(final_update.improvements()), static_cast<int>(received));
  if (!final_update.has_trajectory()) {
    if (!final_update.limits().note().empty()) {
      std::printf("no trajectory within the limits: %s\n", final_update.limits().note().c_str());
    } else {
      std::printf("no admissible trajectory was found\n");
    }
    return;
  }
  const v1::Trajectory& best = final_update.trajectory();
  std::printf("best: risk %.9g expected casualties per flight, length %.1f m, %d waypoints\n",
              best.risk(), best.length_m(), best.waypoints_size());
  if (final_update.wind().speed_mps() > 0.0) {
    std::printf("%s\n", WindText(final_update.wind()).c_str());
  }
  std::printf("%s\n", TargetLevelOfSafetyText(
                          best.risk_per_flight_hour(), best.flight_time_s(),
                          best.flight_time_s() > 0 ? best.length_m() / best.flight_time_s() : 0,
                          o.target_level_of_safety)
                          .c_str());
  std::printf("flight time %.1f s\n", best.flight_time_s());
  // The margin to each limit the request set (what is left of it).
  const v1::FlightLimits& limits = request.limits();
  const auto margin = [](const char* name, double limit, double value, const char* unit) {
    if (limit <= 0.0) return;
    std::printf("limit %s = %g%s: %.6g%s, margin %.6g%s (%.1f %%)\n", name, limit, unit, value,
                unit, limit - value, unit, 100.0 * (limit - value) / limit);
  };
  margin("max_flight_time_s", limits.max_flight_time_s(), best.flight_time_s(), " s");
  margin("max_length_m", limits.max_length_m(), best.length_m(), " m");
  margin("max_risk", limits.max_risk(), best.risk(), "");
  margin("max_risk_per_flight_hour", limits.max_risk_per_flight_hour(),
         best.risk_per_flight_hour(), "");
  if (final_update.front_size() > 0) {
    std::printf("front: %d non-dominated trajectories (flight time s, risk):",
                final_update.front_size());
    for (const v1::Trajectory& t : final_update.front()) {
      std::printf(" (%.1f, %.4g)", t.flight_time_s(), t.risk());
    }
    std::printf("\n");
  }
}

// The ground-station and GIS files of the plan's best trajectory; 0, or the
// exit code of what failed (printed).
int ExportPlan(const CliOptions& o, RiskplanClient& client, const v1::PlanRequest& request,
               const v1::PlanUpdate& final_update, const ExportFiles& exports) {
  // The server samples the best trajectory's path in both frames: the
  // client cannot (it has no map projection), and the same waypoints
  // and parameters give exactly the plan's risk.
  v1::EvaluateRiskRequest eval;
  eval.set_map(o.map);
  eval.mutable_waypoints()->mutable_poses()->CopyFrom(final_update.trajectory().waypoints());
  *eval.mutable_model_params() = request.model_params();
  // The same wind, so that the ground track flown and its times match.
  if (request.has_wind()) *eval.mutable_wind() = request.wind();
  if (request.has_wind_wgs84()) *eval.mutable_wind_wgs84() = request.wind_wgs84();
  eval.set_path_spacing_m(exports.spacing_m);
  v1::EvaluateRiskResponse path;
  if (grpc::Status s = client.EvaluateRisk(eval, &path, TimeoutOr(o, absl::Seconds(30))); !s.ok()) {
    return RpcError(o, "EvaluateRisk", s);
  }
  const std::string description = absl::StrFormat("riskplan plan on %s: %s, seed %d, %s", o.map,
                                                  v1::Algorithm_Name(request.algorithm()), o.seed,
                                                  v1::EndReason_Name(final_update.end_reason()));
  return Export(exports, path, o.map, description);
}

}  // namespace

int RunPlan(const CliOptions& o, RiskplanClient& client) {
  if (!o.mission.empty()) return RunMission(o, client);
  if (!o.mission_out.empty()) return Usage("--mission_out needs --mission=FILE.plan");
  PlanSetup setup;
  if (int code = PreparePlan(o, client, &setup); code != 0) return code;
  const v1::PlanRequest& request = setup.request;
  PictureInput& picture = setup.picture;
  PrintPlanHeader(o, request);
  v1::PlanUpdate final_update;
  grpc::Status status = StreamPlan(o, client, request, &picture.improvements, &final_update);
  if (!status.ok()) return KeepWhatWasReceived(o, client, request, status, setup.exports, picture);

  PrintPlanEnd(o, request, final_update, picture.improvements.size());
  if (final_update.has_trajectory()) {
    if (int code = WriteTrajectoryOut(o, final_update.trajectory()); code != 0) return code;
    if (setup.exports.any()) {
      if (int code = ExportPlan(o, client, request, final_update, setup.exports); code != 0) {
        return code;
      }
    }
  }
  if (!o.picture.empty()) {
    picture.caption = absl::StrFormat(
        "%s, %s: %d improvements, best risk %.4g, length %.0f m, %d iterations (%s)", o.map,
        v1::Algorithm_Name(request.algorithm()), static_cast<int>(picture.improvements.size()),
        final_update.trajectory().risk(), final_update.trajectory().length_m(),
        static_cast<int>(final_update.iterations()), v1::EndReason_Name(final_update.end_reason()));
    if (final_update.front_size() > 0) {
      // The front (--pareto): up to 6 of its routes, from the quickest to the
      // safest, each in its own colour with its flight time and risk in the key.
      // The points nearest to 6 flight times evenly spread over the front's
      // range (the front sorted by flight time), each once.
      const int n = final_update.front_size();
      const double t0 = final_update.front(0).flight_time_s();
      const double t1 = final_update.front(n - 1).flight_time_s();
      std::vector<int> chosen;
      for (int k = 0; k < 6; ++k) {
        const double target = t0 + (t1 - t0) * k / 5.0;
        int best = 0;
        for (int i = 1; i < n; ++i) {
          if (std::abs(final_update.front(i).flight_time_s() - target) <
              std::abs(final_update.front(best).flight_time_s() - target)) {
            best = i;
          }
        }
        if (chosen.empty() || chosen.back() != best) chosen.push_back(best);
      }
      for (int i : chosen) {
        const v1::Trajectory& t = final_update.front(i);
        picture.fleet.push_back(t);
        picture.fleet_labels.push_back(
            absl::StrFormat("front %d/%d: %.0f s, risk %.3g", i + 1, n, t.flight_time_s(), t.risk()));
      }
      picture.fleet_key = true;
      picture.caption += absl::StrFormat("; front of %d routes (risk against flight time)", n);
    }
    if (int code = WritePlanPicture(o, client, request, final_update, picture); code != 0) {
      return code;
    }
  }
  // 3 tells a script that the plan ran but found nothing (NO_SOLUTION, or a
  // SHUTDOWN before the first solution), which is not an RPC failure.
  return final_update.has_trajectory() ? 0 : 3;
}

}  // namespace riskplan::client
