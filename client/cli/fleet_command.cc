// `riskplan fleet --missions=FILE.json`: one PlanFleet call, its progress
// mission by mission as the stream runs, a summary table, a picture of
// every mission's trajectory, and with --report_json the same as JSON.
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "nlohmann/json.hpp"
#include "client/cli/command_support.h"
#include "client/cli/commands.h"
#include "client/cli/fleet_file.h"
#include "client/picture/picture.h"
#include "client/trajectory_text.h"

namespace riskplan::client {
namespace {

// What the summary table says of one mission.
struct MissionRow {
  std::string id;
  int priority = 0;
  std::string algorithm;
  std::string map;
  std::string end = "(none)";  // end reason, or the error's code
  v1::Trajectory best;         // the final trajectory, if any
  bool has_best = false;
  int64_t iterations = 0;
  double elapsed_s = 0.0;
  int order = 0;  // the order it ended in, 1-based
  int call = 0;   // the call (0: the first) that ended it
  std::string replica;  // that call's replica
  int resubmits = 0;    // times it was sent again
  v1::WindReport wind;  // the wind it was planned in
};

// The report of --report_json: the call's outcome and every mission.
nlohmann::json FleetReportJson(const std::string& missions_file, const grpc::Status& status,
                               const std::vector<MissionRow>& rows, int resubmissions) {
  nlohmann::json missions = nlohmann::json::array();
  for (const MissionRow& r : rows) {
    nlohmann::json m = {{"id", r.id},
                        {"priority", r.priority},
                        {"algorithm", r.algorithm},
                        {"map", r.map},
                        {"replica", r.replica},
                        {"end", r.end},
                        {"resubmissions", r.resubmits},
                        {"iterations", r.iterations},
                        {"elapsed_s", r.elapsed_s},
                        {"order", r.order}};
    if (r.has_best) {
      m["risk"] = r.best.risk();
      m["length_m"] = r.best.length_m();
      m["flight_time_s"] = r.best.flight_time_s();
    } else {
      m["risk"] = nullptr;
      m["length_m"] = nullptr;
      m["flight_time_s"] = nullptr;
    }
    missions.push_back(std::move(m));
  }
  return {{"missions_file", missions_file},
          {"status", StatusCodeName(status.error_code())},
          {"message", status.error_message()},
          {"resubmissions", resubmissions},
          {"missions", std::move(missions)}};
}

void PrintUpdate(const v1::FleetUpdate& u, int missions) {
  if (u.error_code() != 0) {
    std::printf("[%d/%d] %s: %s: %s\n", u.missions_ended(), missions, u.mission_id().c_str(),
                StatusCodeName(static_cast<grpc::StatusCode>(u.error_code())).c_str(),
                u.error_message().c_str());
  } else if (!u.update().final()) {
    std::printf("      %s: improvement %d, risk %.6g, length %.1f m, %d iterations\n",
                u.mission_id().c_str(), static_cast<int>(u.update().improvements()),
                u.update().trajectory().risk(), u.update().trajectory().length_m(),
                static_cast<int>(u.update().iterations()));
  } else if (u.update().has_trajectory()) {
    std::printf("[%d/%d] %s: %s, risk %.9g, length %.1f m, %d iterations, %.2f s\n",
                u.missions_ended(), missions, u.mission_id().c_str(),
                v1::EndReason_Name(u.update().end_reason()).c_str(), u.update().trajectory().risk(),
                u.update().trajectory().length_m(), static_cast<int>(u.update().iterations()),
                u.update().elapsed_s());
  } else {
    std::printf("[%d/%d] %s: %s, no trajectory\n", u.missions_ended(), missions,
                u.mission_id().c_str(), v1::EndReason_Name(u.update().end_reason()).c_str());
  }
  std::fflush(stdout);
}

void PrintSummary(const std::vector<MissionRow>& rows) {
  std::printf("\n%-16s %4s %-14s %-16s %14s %10s %10s %9s %5s\n", "mission", "prio", "algorithm",
              "end", "risk", "length_m", "iterations", "elapsed_s", "order");
  for (const MissionRow& r : rows) {
    std::printf("%-16s %4d %-14s %-16s %14s %10s %10d %9.2f %5s\n", r.id.c_str(), r.priority,
                r.algorithm.c_str(), r.end.c_str(),
                r.has_best ? absl::StrFormat("%.9g", r.best.risk()).c_str() : "-",
                r.has_best ? absl::StrFormat("%.1f", r.best.length_m()).c_str() : "-",
                static_cast<int>(r.iterations), r.elapsed_s,
                r.order > 0 ? absl::StrFormat("%d", r.order).c_str() : "-");
  }
}

// The picture of every mission on --map that has a trajectory.
int WriteFleetPicture(const CliOptions& o, const std::vector<MissionRow>& rows,
                      PictureInput& picture) {
  for (const MissionRow& r : rows) {
    if (!r.has_best || r.map != o.map || r.best.waypoints_size() < 2) continue;
    picture.fleet.push_back(r.best);
    picture.fleet_labels.push_back(r.id);
    picture.fleet_starts.push_back(r.best.waypoints(0));
    // The arrow shows the first wind among the missions drawn.
    if (picture.wind.speed_mps() == 0.0) picture.wind = r.wind;
  }
  // A few routes each get their colour and a key of their ids.
  picture.fleet_key = picture.fleet.size() <= 6;
  if (!picture.fleet.empty()) {
    // The local endpoints are the trajectories' own ends (a mission may be
    // given in WGS84); the goal drawn is the first mission's.
    picture.start = picture.fleet_starts.front();
    const v1::Trajectory& first = picture.fleet.front();
    picture.goal = first.waypoints(first.waypoints_size() - 1);
  }
  picture.caption =
      absl::StrFormat("%s: fleet of %d missions, %d trajectories drawn", o.map,
                      static_cast<int>(rows.size()), static_cast<int>(picture.fleet.size()));
  if (absl::Status s = WritePicture(o.picture, picture); !s.ok()) {
    std::fprintf(stderr, "riskplan: %s\n", std::string(s.message()).c_str());
    return 1;
  }
  std::printf("picture: %s\n", o.picture.c_str());
  return 0;
}

// --trajectory_out=F.json: each mission's final waypoints in F-ID.json
// (plan's trajectory JSON), for `riskplan eval --trajectory_file`.
int WriteFleetTrajectories(const CliOptions& o, const std::vector<MissionRow>& rows) {
  if (o.trajectory_out.empty()) return 0;
  std::string stem = o.trajectory_out;
  if (absl::EndsWith(stem, ".json")) stem.resize(stem.size() - 5);
  for (const MissionRow& r : rows) {
    if (!r.has_best) continue;
    const std::string path = absl::StrFormat("%s-%s.json", stem, r.id);
    std::ofstream out(path);
    out << WaypointsToJson(r.best.waypoints());
    out.close();
    if (!out) return Usage(absl::StrFormat("cannot write --trajectory_out: %s", path));
    std::printf("trajectory of %s: %s\n", r.id.c_str(), path.c_str());
  }
  return 0;
}

}  // namespace

int RunFleet(const CliOptions& o, RiskplanClient& client) {
  if (o.missions.empty()) {
    return Usage("--missions=FILE.json is required (docs/api.md, \"Missions files\")");
  }
  absl::StatusOr<v1::FleetRequest> request = ReadMissionsFile(o.missions, o);
  if (!request.ok()) return Usage(std::string(request.status().message()));
  if (absl::Status s = CheckPictureName(o); !s.ok()) return Usage(std::string(s.message()));
  PictureInput picture;
  if (!o.picture.empty()) {
    if (int code = FetchPictureLayers(o, client, &picture); code != 0) return code;
  }
  if (o.max_resubmits < 0 || o.max_resubmits > 10) {
    return Usage(absl::StrFormat("--max_resubmits=%d: must be 0 to 10", o.max_resubmits));
  }
  const int n = request->missions_size();
  std::vector<MissionRow> rows(n);
  for (int i = 0; i < n; ++i) {
    const v1::FleetMission& m = request->missions(i);
    rows[i].id = m.id();
    rows[i].priority = m.priority();
    rows[i].algorithm = v1::Algorithm_Name(m.request().algorithm());
    rows[i].map = m.request().map();
  }
  std::printf(
      "fleet of %d missions from %s%s\n", n, o.missions.c_str(),
      request->tenant().empty() ? "" : absl::StrFormat(", tenant %s", request->tenant()).c_str());
  std::fflush(stdout);
  int order = 0;
  // Which call (and so which replica) each update came in: the calls end in
  // order, each told by on_call_end before the next begins.
  int call = 0;
  std::vector<std::string> call_replicas;
  int resubmissions = 0;
  // No deadline by default, as for `plan`: the budgets bound the missions.
  const absl::Duration timeout = TimeoutOr(o, absl::InfiniteDuration());
  grpc::Status status = client.PlanFleet(
      *request,
      [&](const v1::FleetUpdate& u) {
        PrintUpdate(u, n);
        const int i = u.mission_index();
        if (i < 0 || i >= n) return true;  // not a mission of ours: shown, not kept
        MissionRow& row = rows[i];
        if (u.error_code() != 0) {
          row.end = StatusCodeName(static_cast<grpc::StatusCode>(u.error_code()));
          row.order = ++order;
          row.call = call;
        } else if (u.update().final()) {
          row.end = v1::EndReason_Name(u.update().end_reason());
          row.has_best = u.update().has_trajectory();
          row.best = u.update().trajectory();
          row.wind = u.update().wind();
          row.iterations = u.update().iterations();
          row.elapsed_s = u.update().elapsed_s();
          row.order = ++order;
          // A final held back from a drained call and passed on after the
          // last call ended counts for the last call (clamped below).
          row.call = call;
        }
        return true;
      },
      timeout,
      FleetResubmitOptions{
          .max_resubmits = o.max_resubmits,
          .on_resubmit =
              [&](const FleetResubmission& r) {
                ++resubmissions;
                std::vector<std::string> ids;
                for (int i : r.missions) {
                  if (i < 0 || i >= n) continue;
                  ++rows[i].resubmits;
                  ids.push_back(rows[i].id);
                }
                const std::string replica = r.replica.empty() ? "(unknown)" : r.replica;
                std::string why;
                if (r.drained > 0) {
                  why = absl::StrFormat(
                      "replica %s was draining (shutting down): it ended PlanFleet %s with %d "
                      "missions unplanned",
                      replica, StatusCodeName(r.broken.error_code()), r.drained);
                  if (r.unfinished > r.drained) {
                    absl::StrAppendFormat(&why, " and %d without a result",
                                          r.unfinished - r.drained);
                  }
                } else {
                  why = absl::StrFormat(
                      "PlanFleet on replica %s ended %s%s with %d missions without a result",
                      replica, StatusCodeName(r.broken.error_code()),
                      r.broken.error_message().empty()
                          ? ""
                          : absl::StrFormat(" (%s)", r.broken.error_message()),
                      r.unfinished);
                }
                std::fprintf(stderr,
                             "riskplan: %s (%s); sending them again to another replica "
                             "(re-submission %d)\n",
                             why.c_str(), absl::StrJoin(ids, ", ").c_str(), r.attempt);
              },
          .on_call_end =
              [&](const FleetCallEnd& c) {
                call_replicas.push_back(c.replica.empty() ? "(unknown)" : c.replica);
                ++call;
                if (c.attempt > 0) {
                  std::fprintf(stderr,
                               "riskplan: re-submission %d went to replica %s: %d missions, %d "
                               "ended there (%s)\n",
                               c.attempt, call_replicas.back().c_str(), c.sent, c.ended,
                               StatusCodeName(c.status.error_code()).c_str());
                }
              }});
  for (MissionRow& r : rows) {
    if (r.order > 0 && !call_replicas.empty()) {
      r.replica = call_replicas[std::min<size_t>(r.call, call_replicas.size() - 1)];
    }
  }
  PrintSummary(rows);
  if (!o.picture.empty()) {
    if (int code = WriteFleetPicture(o, rows, picture); code != 0) return code;
  }
  if (!o.report_json.empty()) {
    std::ofstream out(o.report_json);
    out << FleetReportJson(o.missions, status, rows, resubmissions).dump(2) << "\n";
    if (!out) {
      std::fprintf(stderr, "riskplan: cannot write --report_json=%s\n", o.report_json.c_str());
      return 1;
    }
    std::printf("report: %s\n", o.report_json.c_str());
  }
  if (int code = WriteFleetTrajectories(o, rows); code != 0) return code;
  if (!status.ok()) return RpcError(o, "PlanFleet", status);
  // 3: the call succeeded but some mission has no trajectory (its own
  // error, NO_SOLUTION), as `plan` says of its one plan.
  for (const MissionRow& r : rows) {
    if (!r.has_best) return 3;
  }
  return 0;
}

}  // namespace riskplan::client
