// PlanSession: one PlanTrajectory call that riskplan-web runs for browsers,
// and the events it produced, kept so that any number of viewers can watch it
// and a reconnecting viewer resumes after the last event it saw.
// PlanRegistry: the gateway's sessions, bounded.
//
// Threads: each running session has one thread of its own that reads the
// gRPC stream (started by PlanRegistry::Start, joined when the session is
// destroyed); viewers (the HTTP server's threads) wait for events; Cancel
// may come from any thread. Every method is thread-safe.
#ifndef RISKPLAN_WEB_PLAN_SESSION_H_
#define RISKPLAN_WEB_PLAN_SESSION_H_

#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "grpcpp/grpcpp.h"
#include "riskplan/v1/planner.grpc.pb.h"
#include "web/event_log.h"
#include "web/mission_file.h"
#include "web/session_list.h"

namespace riskplan::web {

// The events of a plan (EventLog), as sent to viewers. The types:
//   "update"    an improvement: {"gateway_ms": T, "update": PlanUpdate}
//   "final"     the final PlanUpdate, same form; the stream ends after it
//   "failed"    the call failed: {"code": "INVALID_ARGUMENT", "message":
//               the server's message as it wrote it}; the stream ends (not
//               "error": that name is EventSource's own, for a broken link)
//   "cancelled" the plan was cancelled from the page: {"message": ...}
// T is when the gateway read the message from the server, in milliseconds
// since the Unix epoch (the page measures its drawing latency from it).
// PlanUpdate is the API message in Protobuf's JSON form with the proto's
// field names (docs/api.md; 64-bit integers are JSON strings), its display
// path (Trajectory.path, path_wgs84: for drawing only) rounded to the
// centimetre, which halves an event; the waypoints keep every digit.

enum class PlanState { kRunning, kFinished, kFailed, kCancelled };

// A QGroundControl mission planned leg by leg, as `riskplan plan --mission`
// plans it (docs/api.md, "Missions with waypoints"): every leg's ends checked
// by the server first (a one-iteration plan each, a refusal naming the
// mission item), then each leg a PlanTrajectory call with the session's
// request (its budget per leg) between consecutive mission points, the whole
// mission's limits shared among the legs (client::LegLimits). The events:
//   "update"  {"gateway_ms", "leg": i (from 0), "legs": n, "update": the
//             leg's PlanUpdate}, its elapsed_s, iterations and improvements
//             counted on from the legs before (the leg's final message is
//             an "update" too);
//   "final"   {"gateway_ms", "update": the mission's final PlanUpdate (its
//             trajectory: every leg's waypoints and display paths joined, the
//             risk, length and flight time of one EvaluateRisk of them all),
//             "mission": {"legs": n, "leg_ends": index in the waypoints of
//             each leg's last}}; when a leg finds nothing within its share of
//             the limits, no trajectory and limits.note naming the leg, and
//             "mission": {"legs": n, "failed_leg": i};
//   "failed", "cancelled" as for a plan (a leg's refusal names the leg).
struct MissionPlan {
  std::shared_ptr<const WebMission> mission;
  v1::FlightLimits whole;  // the whole mission's limits (the request's)
};
const char* PlanStateName(PlanState state);

class PlanSession {
 public:
  // `mission` set: a mission planned leg by leg with `request` as every
  // leg's base (its start, goal and limits replaced).
  PlanSession(std::string id, v1::PlanRequest request, PlanEventLimits limits,
              std::shared_ptr<const MissionPlan> mission = nullptr);
  // Cancels the call if it still runs and joins its thread.
  ~PlanSession();
  PlanSession(const PlanSession&) = delete;
  PlanSession& operator=(const PlanSession&) = delete;

  // Starts the call on `stub` in a thread of its own. REQUIRES: called once;
  // `stub` outlives the session.
  void Start(v1::Planner::Stub* stub);

  // Cancels the gRPC call: the server stops the planner within milliseconds.
  // Returns false when the plan had already ended (nothing to cancel).
  bool Cancel();

  // Waits until there is an event with an id above `after_id`, the plan has
  // ended, Stop() was called, or `deadline` passes; then appends the kept
  // events with ids above `after_id` to `*out`, oldest first, stopping once
  // their data reach `max_bytes` (always at least one), so that a viewer
  // catching up on a long plan sends it in pieces. Returns true when no
  // event will ever come after those: the plan ended and `*out` ends with
  // its last event (or it ended before `after_id`), or the session is stopped.
  bool WaitForEvents(uint64_t after_id, absl::Time deadline, std::vector<PlanEvent>* out,
                     size_t max_bytes = size_t{256} << 10) {
    return events_.WaitForEvents(after_id, deadline, out, max_bytes);
  }
  EventLog& events() { return events_; }

  // Wakes every waiting viewer for good (the gateway is shutting down) and
  // cancels the call.
  void Stop();

  const std::string& id() const { return id_; }
  const v1::PlanRequest& request() const { return request_; }
  PlanState state() const;
  bool ended() const;
  uint64_t last_event_id() const;
  // Ids of the oldest and newest events kept (0, 0 when none).
  std::pair<uint64_t, uint64_t> kept_range() const;

 private:
  void Run(v1::Planner::Stub* stub);
  void RunMission(v1::Planner::Stub* stub);  // web/mission_session.cc
  void Append(const std::string& type, std::string data, PlanState end_state);
  // The context of the session's next call, the one Cancel and Stop cancel;
  // null when the session was cancelled or stopped already.
  std::shared_ptr<grpc::ClientContext> NewCall();
  // After a call ended with `status`: appends "cancelled" and returns true
  // when it ended because the page cancelled it.
  bool EndIfCancelled(const grpc::Status& status);
  // NewCall gave null: "cancelled", or "failed" when the gateway stops.
  void EndBeforeCall();

  const std::string id_;
  const v1::PlanRequest request_;
  const std::shared_ptr<const MissionPlan> mission_;
  EventLog events_;
  std::thread thread_;

  mutable absl::Mutex mu_;
  PlanState state_ ABSL_GUARDED_BY(mu_) = PlanState::kRunning;
  bool cancel_requested_ ABSL_GUARDED_BY(mu_) = false;
  bool stopped_ ABSL_GUARDED_BY(mu_) = false;
  std::shared_ptr<grpc::ClientContext> call_ ABSL_GUARDED_BY(mu_);  // TryCancel is thread-safe
};

// The display path (Trajectory.path, path_wgs84) rounded to the centimetre,
// as every event carries it (PlanEvent).
void RoundDisplayPath(v1::Trajectory* t);

struct PlanRegistryLimits {
  int max_running = 4;  // plans running at once; more: ResourceExhausted
  int max_kept = 32;    // sessions kept (ended ones are dropped oldest first)
  PlanEventLimits events;
};

class PlanRegistry {
 public:
  // `stub` must outlive the registry.
  PlanRegistry(v1::Planner::Stub* stub, PlanRegistryLimits limits);
  ~PlanRegistry();  // StopAll()

  // Starts a plan. ResourceExhausted (naming the limit) when max_running
  // plans already run.
  absl::StatusOr<std::shared_ptr<PlanSession>> Start(
      v1::PlanRequest request, std::shared_ptr<const MissionPlan> mission = nullptr);
  // The session `id`, or nullptr.
  std::shared_ptr<PlanSession> Find(const std::string& id) const { return sessions_.Find(id); }
  int running() const { return sessions_.running(); }
  const PlanRegistryLimits& limits() const { return limits_; }
  // Stops every session (Stop) and refuses new plans.
  void StopAll() { sessions_.StopAll(); }

 private:
  v1::Planner::Stub* const stub_;
  const PlanRegistryLimits limits_;
  SessionList<PlanSession> sessions_;
};

// Milliseconds since the Unix epoch, with microseconds: the timestamps of
// the events, comparable with a page's performance.timeOrigin + now().
double EpochMs();

}  // namespace riskplan::web

#endif  // RISKPLAN_WEB_PLAN_SESSION_H_
