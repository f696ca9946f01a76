// PlanCall: one PlanTrajectory stream, from admission to its last message.
//
// Threads that touch a PlanCall:
//   - a gRPC thread creates it (PlannerService::PlanTrajectory) and runs its
//     reactions (OnWriteDone, OnCancel, OnDone);
//   - a plan-pool thread runs Run(): Plan() builds or fetches the risk model,
//     checks the endpoints and plans, offering each improvement; then Run()
//     offers the final message;
//   - the TimerQueue thread sends an update withheld by min_update_interval_ms;
//   - the main thread, on shutdown, calls StopForShutdown (ActivePlans::StopAll).
// All of them meet under mu_, where a PlanCallState (server/plan/plan_call_state.h:
// the phases of the call's end, with its transition table, and the
// UpdateCoalescer that decides what to write) turns each event into a Step.
// The Step is performed after the lock is released: the gRPC operations
// (StartWrite, Finish, which take gRPC's own stream lock), the planner's
// cancellation and timer scheduling never run under mu_, so mu_ never nests
// around another lock and the planner thread holds it only for a few field
// updates.
//
// Ownership: shared_ptrs, its own (dropped in OnDone), the pool task's and
// each timer's, so whichever thread finishes last frees it.
//
// Cancellation: the client's cancel or deadline (OnCancel), a failed write,
// and the server's shutdown (StopForShutdown) all cancel the planner's
// CancellationToken; the planner returns within milliseconds and Run()
// releases the admission slot and ends the call.
#ifndef RISKPLAN_SERVER_PLAN_PLAN_CALL_H_
#define RISKPLAN_SERVER_PLAN_PLAN_CALL_H_

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <set>
#include <string>
#include <string_view>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "accel/risk_engine.h"
#include "core/planners/planner.h"
#include "grpcpp/grpcpp.h"
#include "riskplan/v1/planner.grpc.pb.h"
#include "server/security/auth.h"
#include "server/observability/metrics.h"
#include "server/models/model_cache.h"
#include "server/plan/open_calls.h"
#include "server/plan/plan_call_state.h"
#include "server/plan/plan_evaluator.h"
#include "server/api/request_validation.h"
#include "server/plan/timer_queue.h"

namespace riskplan::server {


// What holds a plan slot: a PlanTrajectory call, or a group of PlanFleet
// missions planned together (server/fleet/fleet_scheduler.h).
class ActivePlan {
 public:
  virtual ~ActivePlan() = default;
  // Stops the planner; the plan ends with end reason SHUTDOWN and its best
  // trajectory so far. Safe from any thread, at any time.
  virtual void StopForShutdown() = 0;
};

// Admission control and the set of running plans (for shutdown). Thread-safe.
class ActivePlans {
 public:
  explicit ActivePlans(int max_running) : max_running_(max_running) {}

  // Admits `plan` unless `max_running` plans are already admitted.
  bool TryAdmit(const std::shared_ptr<ActivePlan>& plan);
  // Frees the slot of an admitted plan, then (outside the lock) calls the
  // release listener. Idempotent.
  void Release(const ActivePlan* plan);
  // Whether `plan` holds a slot (admitted and not yet released).
  bool IsAdmitted(const ActivePlan* plan) const;
  // Called after every Release that freed a slot (the fleet scheduler starts
  // its next group). Set once, before any plan is admitted.
  void SetReleaseListener(std::function<void()> listener) { listener_ = std::move(listener); }
  // Cancels every admitted plan with end reason SHUTDOWN.
  void StopAll();
  // Waits until no plan is admitted or `deadline` passes; true when none is.
  bool WaitUntilIdle(absl::Time deadline);
  int running() const;
  int max_running() const { return max_running_; }

 private:
  const int max_running_;
  std::function<void()> listener_;
  mutable absl::Mutex mu_;
  std::set<std::shared_ptr<ActivePlan>> calls_ ABSL_GUARDED_BY(mu_);
};

// What a PlanCall needs from the server; every pointer outlives the calls.
struct PlanCallEnv {
  RiskModelCache* models = nullptr;
  ServerMetrics* metrics = nullptr;
  TimerQueue* timer = nullptr;
  ActivePlans* active = nullptr;
  accel::RiskEngine* engine = nullptr;  // null: the planner's own evaluator
  OpenCalls* open_calls = nullptr;      // counts the call until its OnDone
};

// Writes each PlanUpdate serialised by the service itself (the method is
// raw, see server/api/message_codec.h).
class PlanCall final : public grpc::ServerWriteReactor<grpc::ByteBuffer>,
                       public ActivePlan,
                       public std::enable_shared_from_this<PlanCall> {
 public:
  // A call for a validated request. Call Start() next.
  // `caller` is who made it (server/security/auth.h), for the log and the metrics.
  static std::shared_ptr<PlanCall> Create(const PlanCallEnv& env, grpc::CallbackServerContext* ctx,
                                          PlanSpec spec, Caller caller = {});

  // Checks the endpoints at once when the risk model is cached (so a bad
  // start or goal fails before any queueing). Returns an error status, with
  // the call not yet admitted, if they are not admissible; else OK, and the
  // caller admits and schedules the call.
  absl::Status CheckEndpointsIfModelReady();

  // Plans on the calling (pool) thread, streams the results, and releases the
  // admission slot (and the running-plans gauge) before the final message is
  // offered. An exception thrown while planning (std::bad_alloc) ends the
  // call with StatusFromException's status instead of leaving the thread.
  // REQUIRES: admitted, and PlanAdmitted() recorded.
  void Run();

  // Ends the call with `status` without planning (admission or scheduling
  // refused it). Safe from any thread, once, before Run().
  void Reject(const grpc::Status& status);

  // Cancels the planner; the plan ends with end reason SHUTDOWN and its best
  // trajectory so far. Safe from any thread, at any time.
  void StopForShutdown() override;

  // grpc::ServerWriteReactor.
  void OnWriteDone(bool ok) override;
  void OnCancel() override;
  void OnDone() override;

 private:
  using State = PlanCallState<v1::PlanUpdate>;
  using Step = State::Step;

  PlanCall(const PlanCallEnv& env, grpc::CallbackServerContext* ctx, PlanSpec spec,
           Caller caller);

  // The planning step: model, endpoints, planner, plan. A call cancelled
  // while queued returns an empty result with StopReason::kCancelled.
  absl::StatusOr<PlanResult> Plan();
  // Offers the final message of `result` (or ends the call if nobody listens).
  void OfferFinal(const PlanResult& result) ABSL_LOCKS_EXCLUDED(mu_);
  void OnImprovement(const PlanImprovement& improvement) ABSL_LOCKS_EXCLUDED(mu_);
  void OnTimer() ABSL_LOCKS_EXCLUDED(mu_);
  // Finishes the call with `status` once no write is in flight.
  void FinishWith(const grpc::Status& status) ABSL_LOCKS_EXCLUDED(mu_);
  // Moves the message of `step`, if any, into write_buffer_ and numbers it;
  // step->write stays engaged, telling Perform to start the write.
  void TakeWriteLocked(Step* step) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Performs a Step the state returned: called without mu_ held.
  void Perform(const Step& step) ABSL_LOCKS_EXCLUDED(mu_);
  // Serialises write_buffer_ into raw_write_, for the write a Step starts.
  // Outside mu_: from the Step that starts a write until its OnWriteDone
  // nothing else touches either buffer (one write in flight at a time).
  absl::Status SerializeWrite() ABSL_NO_THREAD_SAFETY_ANALYSIS;
  // Logs an update that could not be built (a bug, see OnImprovement).
  void LogUpdateFailed(std::string_view which, const absl::Status& status) const;

  const PlanCallEnv env_;
  grpc::CallbackServerContext* const ctx_;  // valid until OnDone
  const PlanSpec spec_;
  const absl::Time started_;
  const std::string peer_;
  const Caller caller_;
  std::shared_ptr<PlanCall> self_;  // gRPC's reference, dropped in OnDone
  // Cancelled only by Perform, for Steps with stop_planner; read by the
  // planner without any lock.
  CancellationToken cancel_;
  // Set by CheckEndpointsIfModelReady on the gRPC thread before the call is
  // queued, read by Plan() on the pool thread (the pool's queue orders the
  // two; atomic so that this does not have to be argued).
  std::atomic<bool> endpoints_checked_{false};

  absl::Mutex mu_;
  State state_ ABSL_GUARDED_BY(mu_);
  // The message in flight, and its serialised form, which gRPC reads
  // between StartWrite and OnWriteDone, outside mu_. Both are only replaced
  // when the state has no write in flight (see SerializeWrite).
  v1::PlanUpdate write_buffer_ ABSL_GUARDED_BY(mu_);
  grpc::ByteBuffer raw_write_;
  uint64_t sent_ ABSL_GUARDED_BY(mu_) = 0;         // PlanUpdate.sequence of the last write
  int64_t improvements_ ABSL_GUARDED_BY(mu_) = 0;  // the planner's, sent or not
  std::string log_detail_ ABSL_GUARDED_BY(mu_);    // end reason and counts, for OnDone
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_PLAN_PLAN_CALL_H_
