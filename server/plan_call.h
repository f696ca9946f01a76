// PlanCall: one PlanTrajectory stream, from admission to its last message.
//
// Threads that touch a PlanCall:
//   - a gRPC thread creates it (PlannerService::PlanTrajectory) and runs its
//     reactions (OnWriteDone, OnCancel, OnDone);
//   - a plan-pool thread runs Run(): builds or fetches the risk model, checks
//     the endpoints, plans, and offers each improvement and the final message;
//   - the TimerQueue thread sends an update withheld by min_update_interval_ms.
// All three meet under mu_, where an UpdateCoalescer decides what to write;
// the gRPC operations themselves (StartWrite, Finish) are started after the
// lock is released. The call is owned by shared_ptrs: its own (dropped in
// OnDone), the pool task's and each timer's, so whichever thread finishes
// last frees it.
//
// Cancellation: the client's cancel or deadline (OnCancel), a failed write,
// and the server's shutdown (StopForShutdown) all cancel the planner's
// CancellationToken; the planner returns within milliseconds and Run()
// releases the admission slot.
#ifndef RISKPLAN_SERVER_PLAN_CALL_H_
#define RISKPLAN_SERVER_PLAN_CALL_H_

#include <atomic>
#include <cstdint>
#include <memory>
#include <set>
#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "accel/risk_engine.h"
#include "core/planners/planner.h"
#include "grpcpp/grpcpp.h"
#include "riskplan/v1/planner.grpc.pb.h"
#include "server/metrics.h"
#include "server/model_cache.h"
#include "server/open_calls.h"
#include "server/request_validation.h"
#include "server/timer_queue.h"
#include "server/update_coalescer.h"

namespace riskplan::server {

class PlanCall;

// Admission control and the set of running plans (for shutdown). Thread-safe.
class ActivePlans {
 public:
  explicit ActivePlans(int max_running) : max_running_(max_running) {}

  // Admits `call` unless `max_running` plans are already admitted.
  bool TryAdmit(const std::shared_ptr<PlanCall>& call);
  // Frees the slot of an admitted call. Idempotent.
  void Release(const PlanCall* call);
  // Cancels every admitted plan with end reason SHUTDOWN.
  void StopAll();
  // Waits until no plan is admitted or `deadline` passes; true when none is.
  bool WaitUntilIdle(absl::Time deadline);
  int running() const;
  int max_running() const { return max_running_; }

 private:
  const int max_running_;
  mutable absl::Mutex mu_;
  std::set<std::shared_ptr<PlanCall>> calls_ ABSL_GUARDED_BY(mu_);
};

// What a PlanCall needs from the server; every pointer outlives the calls.
struct PlanCallEnv {
  RiskModelCache* models = nullptr;
  ServerMetrics* metrics = nullptr;
  TimerQueue* timer = nullptr;
  ActivePlans* active = nullptr;
  accel::RiskEngine* engine = nullptr;  // null: the planner's own evaluator
  OpenCalls* open_calls = nullptr;       // counts the call until its OnDone
};

class PlanCall final : public grpc::ServerWriteReactor<v1::PlanUpdate>,
                       public std::enable_shared_from_this<PlanCall> {
 public:
  // A call for a validated request. Call Start() next.
  static std::shared_ptr<PlanCall> Create(const PlanCallEnv& env, grpc::CallbackServerContext* ctx,
                                          PlanSpec spec);

  // Checks the endpoints at once when the risk model is cached (so a bad
  // start or goal fails before any queueing). Returns an error status, with
  // the call not yet admitted, if they are not admissible; else OK, and the
  // caller admits and schedules the call.
  absl::Status CheckEndpointsIfModelReady();

  // Plans on the calling (pool) thread, streams the results, and releases the
  // admission slot (and the running-plans gauge) before the final message is
  // offered. REQUIRES: admitted, and PlanAdmitted() recorded.
  void Run();

  // Ends the call with `status` without planning (admission or scheduling
  // refused it). Safe from any thread, once, before Run().
  void Reject(const grpc::Status& status);

  // Cancels the planner; the plan ends with end reason SHUTDOWN and its best
  // trajectory so far.
  void StopForShutdown();

  // grpc::ServerWriteReactor.
  void OnWriteDone(bool ok) override;
  void OnCancel() override;
  void OnDone() override;

 private:
  using Step = UpdateCoalescer<v1::PlanUpdate>::Step;

  PlanCall(const PlanCallEnv& env, grpc::CallbackServerContext* ctx, PlanSpec spec);

  void OnImprovement(const PlanImprovement& improvement);
  void OnTimer();
  // Performs a Step the coalescer returned: called without mu_ held.
  void Perform(Step step) ABSL_LOCKS_EXCLUDED(mu_);
  // Finishes the call with `status` once no write is in flight.
  void FinishWith(const grpc::Status& status) ABSL_LOCKS_EXCLUDED(mu_);
  // Prepares the message of a Step for writing; returns whether to write.
  bool TakeWriteLocked(Step* step) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  v1::PlanUpdate FinalUpdate(const PlanResult& result);

  const PlanCallEnv env_;
  grpc::CallbackServerContext* const ctx_;  // valid until OnDone
  const PlanSpec spec_;
  const absl::Time started_;
  const std::string peer_;
  std::shared_ptr<PlanCall> self_;  // gRPC's reference, dropped in OnDone
  CancellationToken cancel_;
  std::atomic<bool> shutdown_{false};
  std::atomic<bool> endpoints_checked_{false};

  absl::Mutex mu_;
  UpdateCoalescer<v1::PlanUpdate> coalescer_ ABSL_GUARDED_BY(mu_);
  v1::PlanUpdate write_buffer_ ABSL_GUARDED_BY(mu_);  // the message in flight
  uint64_t sent_ ABSL_GUARDED_BY(mu_) = 0;
  int64_t improvements_ ABSL_GUARDED_BY(mu_) = 0;
  bool cancelled_ ABSL_GUARDED_BY(mu_) = false;     // OnCancel ran
  bool deadline_hit_ ABSL_GUARDED_BY(mu_) = false;  // ... because of the deadline
  bool write_failed_ ABSL_GUARDED_BY(mu_) = false;
  bool finish_started_ ABSL_GUARDED_BY(mu_) = false;  // Finish() called or decided
  std::optional<grpc::Status> finish_when_idle_ ABSL_GUARDED_BY(mu_);
  grpc::Status final_status_ ABSL_GUARDED_BY(mu_);
  std::string log_detail_ ABSL_GUARDED_BY(mu_);
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_PLAN_CALL_H_
