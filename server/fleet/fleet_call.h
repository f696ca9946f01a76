// FleetCall: one PlanFleet stream, from its first message to its status.
//
// Threads that touch a FleetCall:
//   - a gRPC thread creates it (PlannerService::PlanFleet), offers the errors
//     of the missions that failed validation (Start), and runs its reactions
//     (OnWriteDone, OnCancel, OnDone);
//   - plan-pool threads, one per mission group (server/fleet/fleet_scheduler.h),
//     offer improvements and results, and say when their group has ended;
//   - the main thread, on shutdown, stops the planners (StopForShutdown).
// They meet under mu_, where a FleetCallState (server/fleet/fleet_call_state.h:
// the phases of the call, with its transition table, and the messages
// waiting to be written) turns each event into a Step. The Step is performed
// after mu_ is released: gRPC operations (StartWrite, Finish), the cancel
// token and the cancel hook never run under it.
//
// The stream. At most one write is in flight. Final messages (a mission's
// result or its error) wait in order of arrival and are never dropped.
// Improvements (only with send_improvements) wait one per mission, a newer
// one replacing the older, and are written after every waiting final once at
// least the mission's min_update_interval_ms has passed since its previous
// improvement was written; one that is not yet due waits for the next write
// or offer, and a mission's final replaces it.
//
// The end. Finish(OK) once every group has ended and every final message is
// written. The client's cancel, its deadline or a failed write stop every
// planner (the cancel token, and the hook that drops the groups still
// queued) and Finish(CANCELLED) once every group has ended.
//
// Ownership: shared_ptrs, its own (dropped in OnDone) and each group's.
#ifndef RISKPLAN_SERVER_FLEET_FLEET_CALL_H_
#define RISKPLAN_SERVER_FLEET_FLEET_CALL_H_

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "core/base/cancellation.h"
#include "core/planners/planner.h"
#include "grpcpp/grpcpp.h"
#include "riskplan/v1/planner.pb.h"
#include "server/fleet/fleet_call_state.h"
#include "server/fleet/fleet_request.h"
#include "server/observability/metrics.h"
#include "server/plan/open_calls.h"
#include "server/security/auth.h"

namespace riskplan::server {

class FleetCall final : public grpc::ServerWriteReactor<grpc::ByteBuffer>,
                        public std::enable_shared_from_this<FleetCall> {
 public:
  // `metrics` and `open_calls` outlive the call.
  static std::shared_ptr<FleetCall> Create(grpc::CallbackServerContext* ctx, ServerMetrics* metrics,
                                           OpenCalls* open_calls, Caller caller);

  // Ends the call with `status` before Start (refused). Once.
  void Reject(const grpc::Status& status);

  // Begins the stream of a validated fleet whose valid missions are planned
  // in `groups` groups (each reports GroupEnded once): the errors of the
  // invalid missions are offered now. `on_cancel` is run (once, outside the
  // call's lock) when the client goes: it drops the call's queued groups.
  void Start(std::shared_ptr<const FleetSpec> spec, int groups, std::function<void()> on_cancel);

  // From a group's planning thread. `mission` indexes spec->missions.
  void OfferImprovement(size_t mission, const PlanImprovement& improvement)
      ABSL_LOCKS_EXCLUDED(mu_);
  void OfferResult(size_t mission, const absl::StatusOr<PlanResult>& result)
      ABSL_LOCKS_EXCLUDED(mu_);
  // A group has delivered every result it will (or was dropped unplanned).
  void GroupEnded() ABSL_LOCKS_EXCLUDED(mu_);

  // Cancelled when the client goes or the server shuts down: every planner
  // of the call stops on it.
  const CancellationToken& cancel_token() const { return cancel_; }
  // Stops every planner of the call; results end with SHUTDOWN.
  void StopForShutdown();
  // Results cut short from now on end with SHUTDOWN, without stopping the
  // planners (a group dropped by the drain while the others plan on).
  void MarkShutdown() { shutdown_.store(true); }
  // Who called, and the fair-share identity (server/fleet/fleet_queue.h).
  const Caller& caller() const { return caller_; }

  // grpc::ServerWriteReactor.
  void OnWriteDone(bool ok) override;
  void OnCancel() override;
  void OnDone() override;

 private:
  FleetCall(grpc::CallbackServerContext* ctx, ServerMetrics* metrics, OpenCalls* open_calls,
            Caller caller);

  using State = FleetCallState<v1::FleetUpdate>;
  using Step = State::Step;

  // Offers `update` as mission `mission`'s final message.
  void OfferFinal(size_t mission, v1::FleetUpdate update) ABSL_LOCKS_EXCLUDED(mu_);
  // Moves the message of `step`, if any, into write_buffer_ and numbers it;
  // step->write stays engaged, telling Perform to start the write.
  void TakeWriteLocked(Step* step) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Performs a Step the state returned: called without mu_ held.
  void Perform(const Step& step) ABSL_LOCKS_EXCLUDED(mu_);

  grpc::CallbackServerContext* const ctx_;
  ServerMetrics* const metrics_;
  OpenCalls* const open_calls_;
  const Caller caller_;
  const absl::Time started_;
  const std::string peer_;
  std::shared_ptr<FleetCall> self_;  // gRPC's reference, dropped in OnDone
  CancellationToken cancel_;
  std::atomic<bool> shutdown_{false};
  std::function<void()> on_cancel_;  // set by Start, run once by Perform

  absl::Mutex mu_;
  std::shared_ptr<const FleetSpec> spec_ ABSL_GUARDED_BY(mu_);
  State state_ ABSL_GUARDED_BY(mu_);
  std::vector<uint64_t> mission_sequence_ ABSL_GUARDED_BY(mu_);     // by mission
  std::vector<int64_t> mission_improvements_ ABSL_GUARDED_BY(mu_);  // by mission
  int missions_ended_ ABSL_GUARDED_BY(mu_) = 0;
  int completed_ ABSL_GUARDED_BY(mu_) = 0;  // finals with a PlanUpdate
  int failed_ ABSL_GUARDED_BY(mu_) = 0;     // finals with an error
  uint64_t sent_ ABSL_GUARDED_BY(mu_) = 0;
  // The message in flight and its bytes: only the thread that started the
  // write touches them until OnWriteDone (one write in flight).
  v1::FleetUpdate write_buffer_;
  grpc::ByteBuffer raw_write_;
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_FLEET_FLEET_CALL_H_
