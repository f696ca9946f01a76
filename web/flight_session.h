// FlightSession: one in-flight session (the Fly RPC, docs/in-flight.md) that
// riskplan-web runs for browsers. The gateway itself flies a simulated
// aircraft along the session's plan, as `riskplan fly --scenario` does: at
// the plan's mean ground speed (the route's length over its flight time),
// `speedup` times faster than real time, a position report every
// FlightGatewayLimits::report_every of real time (while an alert is in
// force it goes no further than the commit point: the remainder is not to be
// flown; a real aircraft would divert to the alert's landing site); the page
// adds and removes
// zones (and may change the wind), and sees the server's plan versions,
// alerts and refusals as events. The stream goes through the client
// library's FlightLink, which resumes the session on a replica when a
// stream breaks.
// FlightRegistry: the gateway's flights, bounded.
//
// Threads: each flight has one thread of its own that flies the aircraft
// (started by FlightRegistry::Start, joined when the session is destroyed),
// and the link's reader thread, which appends the server's outputs; viewers
// (the HTTP server's threads) wait for events; Input and End may come from
// any thread. Every method is thread-safe.
#ifndef RISKPLAN_WEB_FLIGHT_SESSION_H_
#define RISKPLAN_WEB_FLIGHT_SESSION_H_

#include <cstdint>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "client/flight_link.h"
#include "grpcpp/grpcpp.h"
#include "riskplan/v1/planner.pb.h"
#include "web/event_log.h"
#include "web/session_list.h"

namespace riskplan::web {

// The events of a flight (docs/web.md, "Flight"), each JSON with
// "gateway_ms" (when the gateway appended it, ms since 1970):
//   "version"   {"version": FlightPlanVersion} (display paths rounded to the
//               centimetre, as a plan's)
//   "alert"     {"alert": FlightAlert}
//   "refusal"   {"refusal": FlightRefusal}: an input the server refused; the
//               flight goes on
//   "position"  {"time_s", "progress_m", "x", "y", "z"[, "lat_deg",
//               "lon_deg"]}: the simulated aircraft, on the latest route
//   "resumed"   {"message"}: the stream broke and the link resumed the session
//   "ended"     {"message", "time_s", "progress_m"}: the flight ended (at the
//               goal, from the page, or at the flight-time bound); last
//   "failed"    {"code", "message"}: the session failed (a refused opening,
//               the server's words untouched); last
struct FlightGatewayLimits {
  int max_running = 2;  // flights at once (--max_flights); more: ResourceExhausted
  int max_kept = 8;     // flights kept (ended ones dropped oldest first)
  int max_zones = 16;   // zones the page holds on one flight at once (--max_flight_zones)
  // Zone and wind changes of one flight: at most this many a second, in
  // bursts of as many.
  double max_changes_per_s = 4.0;
  double max_speedup = 100.0;                             // speedup in [1, max_speedup]
  double max_flight_time_s = 3600;                        // of flight time, then the flight ends
  absl::Duration report_every = absl::Milliseconds(100);  // real time between reports
  absl::Duration first_version_timeout = absl::Seconds(120);
  PlanEventLimits events;
};

class FlightSession {
 public:
  FlightSession(std::string id, v1::FlightOpen open, double speedup, FlightGatewayLimits limits);
  // Stops the flight and joins its thread.
  ~FlightSession();
  FlightSession(const FlightSession&) = delete;
  FlightSession& operator=(const FlightSession&) = delete;

  // Opens the session on `channel` and starts flying in a thread of its own.
  // REQUIRES: called once.
  void Start(std::shared_ptr<grpc::Channel> channel);

  // A zone added or removed, or a new wind, from the page. InvalidArgument
  // for any other input, FailedPrecondition before the first plan version or
  // after the flight ended, ResourceExhausted past the zone or rate bounds;
  // each names the bound. The server's own refusal arrives as a "refusal"
  // event.
  absl::Status Input(const v1::FlightInput& input);
  // Ends the flight (the aircraft stops where it is, the session ends).
  // False when it had ended already.
  bool End();
  // Wakes every viewer for good and ends the flight (the gateway stops).
  void Stop();

  const std::string& id() const { return id_; }
  EventLog& events() { return events_; }
  bool ended() const { return events_.ended(); }
  // "opening", "flying", "ended", "failed".
  std::string state() const;

 private:
  void Run(std::shared_ptr<grpc::Channel> channel);
  void OnOutput(const v1::FlightOutput& out);
  void AppendJson(const std::string& type, const std::string& fields, bool terminal);
  // Waits `d` of real time; false when the flight is to end.
  bool Wait(absl::Duration d);

  const std::string id_;
  const v1::FlightOpen open_;
  const double speedup_;
  const FlightGatewayLimits limits_;
  EventLog events_;
  std::unique_ptr<client::FlightLink> link_;
  std::thread thread_;

  mutable absl::Mutex mu_;
  bool opened_ ABSL_GUARDED_BY(mu_) = false;  // a first version came (set before its event)
  bool end_requested_ ABSL_GUARDED_BY(mu_) = false;
  bool stopped_ ABSL_GUARDED_BY(mu_) = false;
  bool failed_ ABSL_GUARDED_BY(mu_) = false;
  bool alert_in_force_ ABSL_GUARDED_BY(mu_) = false;  // an alert came after the latest version
  std::set<std::string> zones_ ABSL_GUARDED_BY(mu_);  // added from the page, not removed
  double tokens_ ABSL_GUARDED_BY(mu_);                // the change rate's bucket
  absl::Time tokens_at_ ABSL_GUARDED_BY(mu_);
};

class FlightRegistry {
 public:
  explicit FlightRegistry(FlightGatewayLimits limits) : limits_(limits) {}
  ~FlightRegistry();  // StopAll()

  // Checks what the gateway bounds of a flight (InvalidArgument naming the
  // field), then starts it on `channel`. ResourceExhausted (naming the
  // limit) when max_running flights fly already.
  absl::StatusOr<std::shared_ptr<FlightSession>> Start(v1::FlightOpen open, double speedup,
                                                       std::shared_ptr<grpc::Channel> channel);
  std::shared_ptr<FlightSession> Find(const std::string& id) const { return sessions_.Find(id); }
  int running() const { return sessions_.running(); }
  const FlightGatewayLimits& limits() const { return limits_; }
  void StopAll() { sessions_.StopAll(); }

 private:
  const FlightGatewayLimits limits_;
  SessionList<FlightSession> sessions_;
};

}  // namespace riskplan::web

#endif  // RISKPLAN_WEB_FLIGHT_SESSION_H_
