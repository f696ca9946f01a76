// FlightCall: the reactor of one Fly stream (proto/riskplan/v1/flight.proto).
//
// Threads: gRPC's threads run the reactions (OnReadDone, OnWriteDone,
// OnCancel, OnDone); the plan pool runs the session (FlightSession), one
// step at a time: one input, or one search while an alert is in force and
// no input waits. A step is a pool task of its own, so a session that keeps
// searching never holds a plan thread longer than one replanning budget.
// Everything meets under mu_; gRPC operations start after it is released.
//
// Bounds: at most kMaxQueuedInputs inputs wait (a client that sends faster
// than the session handles them is ended with RESOURCE_EXHAUSTED), and at
// most kMaxQueuedOutputs outputs (a client that does not read).
//
// Admission: a session holds one of ActivePlans' slots from its opening to
// its end, like a plan; the drain ends it with UNAVAILABLE (the client
// resumes on another replica).
#ifndef RISKPLAN_SERVER_FLIGHT_FLIGHT_CALL_H_
#define RISKPLAN_SERVER_FLIGHT_FLIGHT_CALL_H_

#include <deque>
#include <memory>
#include <optional>
#include <string>

#include "absl/time/time.h"

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "core/base/cancellation.h"
#include "grpcpp/grpcpp.h"
#include "riskplan/v1/planner.grpc.pb.h"
#include "server/flight/flight_session.h"
#include "server/observability/metrics.h"
#include "server/security/auth.h"
#include "server/plan/open_calls.h"
#include "server/plan/plan_call.h"
#include "server/plan/thread_pool.h"

namespace riskplan::server {

inline constexpr size_t kMaxQueuedInputs = 256;
inline constexpr size_t kMaxQueuedOutputs = 1024;

struct FlightCallEnv {
  FlightEnv flight;
  ActivePlans* active = nullptr;
  ThreadPool* pool = nullptr;
  ServerMetrics* metrics = nullptr;
  OpenCalls* open_calls = nullptr;
};

class FlightCall final : public grpc::ServerBidiReactor<v1::FlightInput, v1::FlightOutput>,
                         public ActivePlan,
                         public std::enable_shared_from_this<FlightCall> {
 public:
  // `caller` is who made it (server/security/auth.h), for the log and the metrics.
  static std::shared_ptr<FlightCall> Create(const FlightCallEnv& env,
                                            grpc::CallbackServerContext* ctx, Caller caller = {});

  // Admitted: starts reading. Call once, after ActivePlans admitted it.
  void Start();
  // Ends the call with `status` before anything was read.
  void Reject(const grpc::Status& status);

  void StopForShutdown() override;

  void OnReadDone(bool ok) override;
  void OnWriteDone(bool ok) override;
  void OnCancel() override;
  void OnDone() override;

 private:
  FlightCall(const FlightCallEnv& env, grpc::CallbackServerContext* ctx, Caller caller);

  // One step of the session on a pool thread.
  void Step();
  // Queues a step unless one is queued or running. REQUIRES mu_.
  bool ScheduleLocked() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Decides the finish; performed by MaybeFinish once no write is in flight.
  void EndLocked(const grpc::Status& status) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Starts the next write or the finish, if due. Called without mu_.
  void Pump() ABSL_LOCKS_EXCLUDED(mu_);
  // Queues an output the step made before its end (the session's early
  // sink: a change's first admissible remainder) and starts writing it.
  void EmitEarly(v1::FlightOutput output) ABSL_LOCKS_EXCLUDED(mu_);
  // Counts and queues `output`. REQUIRES mu_.
  void QueueLocked(v1::FlightOutput output) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  const FlightCallEnv env_;
  const absl::Time started_;
  const std::string peer_;
  const Caller caller_;
  std::shared_ptr<FlightCall> self_;  // gRPC's reference, dropped in OnDone
  CancellationToken cancel_;          // the stream broke, or the drain
  CancellationToken shutdown_;

  // Only the step running on the pool touches the session.
  FlightSession session_;

  // Orders StartRead after Finish out: a read started by OnReadDone races a
  // finish decided on another thread (the drain, a failed write). Held only
  // around those two non-blocking calls, never with mu_.
  absl::Mutex ops_mu_;
  bool finish_started_ ABSL_GUARDED_BY(ops_mu_) = false;

  absl::Mutex mu_;
  v1::FlightInput read_buffer_;  // filled by gRPC between StartRead and OnReadDone
  std::deque<v1::FlightInput> inputs_ ABSL_GUARDED_BY(mu_);
  std::deque<v1::FlightOutput> outputs_ ABSL_GUARDED_BY(mu_);
  v1::FlightOutput write_buffer_ ABSL_GUARDED_BY(mu_);
  bool writing_ ABSL_GUARDED_BY(mu_) = false;
  bool step_scheduled_ ABSL_GUARDED_BY(mu_) = false;
  bool reads_done_ ABSL_GUARDED_BY(mu_) = false;
  std::optional<grpc::Status> end_ ABSL_GUARDED_BY(mu_);
  bool finished_ ABSL_GUARDED_BY(mu_) = false;
  grpc::Status finish_status_ ABSL_GUARDED_BY(mu_);
  // Counts for the log line.
  int64_t inputs_read_ ABSL_GUARDED_BY(mu_) = 0;
  int64_t versions_ ABSL_GUARDED_BY(mu_) = 0;
  int64_t alerts_ ABSL_GUARDED_BY(mu_) = 0;
  int64_t refusals_ ABSL_GUARDED_BY(mu_) = 0;
  std::string map_ ABSL_GUARDED_BY(mu_);
  bool admitted_ ABSL_GUARDED_BY(mu_) = false;
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_FLIGHT_FLIGHT_CALL_H_
