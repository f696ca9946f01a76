// PlanCallState: how a plan stream ends, written out as a state machine.
//
// A PlanTrajectory stream can end in several ways that race with each other:
// the planner finishes (with a result or an error), the client cancels or its
// deadline passes, a write fails because the client is gone, the server shuts
// down, or the call is refused before it plans. Whatever the order, gRPC's
// Finish() must be called exactly once, only when no write is in flight, and
// never before Run() is done with the stream. This class decides when.
//
// Pure logic, no gRPC calls, no locking, no clock (like the UpdateCoalescer it
// drives for the writes themselves): PlanCall feeds it every event under its
// own mutex and performs the Step it gets back once the lock is released.
//
// Phases (PlanCallPhase):
//   kPlanning        initial; the plan is queued or running and its
//                    improvements are written (through the coalescer)
//   kStopping        the client is gone (it cancelled, its deadline passed,
//                    or a write failed): the planner is being stopped and
//                    nothing new is offered; Run() ends the call
//   kFinalOffered    Run() offered the final message; the call finishes once
//                    the coalescer reports it written
//   kFinishWhenIdle  the end is decided, with its status, but a write is in
//                    flight: Finish() waits for its completion
//   kFinished        Finish() was started; terminal
// Beside the phase it keeps the cancel cause (none, client, deadline: what
// the log and metrics report), whether the server's shutdown stopped the
// plan (its end reason is SHUTDOWN), and the status Finish() is given.
//
// Transitions. "In flight": the coalescer has a write in flight. Every event
// not listed for a phase leaves everything unchanged and does nothing.
//   from              event            to               action
//   kPlanning         Offer, Poll      kPlanning        the coalescer's step: write now,
//                                                       hold back (wake-up), or replace
//   kPlanning         EndPlan(final)   kFinalOffered    the coalescer writes the final
//                                                       message now or after the write in flight
//   kStopping         EndPlan(final)   kFinished        Finish(CANCELLED), the final dropped
//                                      kFinishWhenIdle  ... if in flight: the same, later
//   kPlanning,        RequestFinish(s) kFinished        Finish(s)
//     kStopping                        kFinishWhenIdle  ... if in flight: keep s
//   kPlanning,        WriteDone        (same)           the coalescer's next write or wake-up
//     kStopping                                         (an update it held may still go out)
//   kFinalOffered     WriteDone        kFinalOffered    the final message's write, if it waited
//                                      kFinished        Finish(OK) once the final is written
//   kFinishWhenIdle   WriteDone        kFinished        Finish(the kept status)
//   kPlanning         WriteFailed      kStopping        stop the planner
//   kStopping         WriteFailed      kStopping        stop the planner
//   kFinalOffered,    WriteFailed      kFinished        stop the planner; Finish(CANCELLED,
//     kFinishWhenIdle                                   "the stream broke")
//   kPlanning         Cancel(cause)    kStopping        record the cause; stop the planner
//   any other         Cancel(cause)    (same)           record the cause; stop the planner
//   any               Shutdown         (same)           record it; stop the planner
//
// Events: Offer (an improvement), Poll (a wake-up the coalescer asked for is
// due), EndPlan (the planner returned a result), RequestFinish (the call is
// refused before planning, or planning failed), WriteDone and WriteFailed
// (gRPC's OnWriteDone(ok) and OnWriteDone(!ok), so only with a write in
// flight, which never is in kFinished), Cancel (gRPC's OnCancel), Shutdown
// (the server's drain stops the plan).
//
// Why these rules:
//   - Only kPlanning offers improvements: once the client is gone or the end
//     is decided, a new update has no reader.
//   - A client cancel or deadline does not finish the call by itself: the
//     planner is still running on a pool thread and holds the call; Run()
//     finishes it when the planner has returned (EndPlan or RequestFinish).
//     A write failure finishes it at once only when Run() has already ended.
//   - The cause of a cancel is kept even after Finish(): gRPC may report the
//     cancel after the status was decided, and the client saw the cancel.
//   - Finish() is never started while a write is in flight, so that the
//     status follows every message started and no write completes on a
//     finished call; kFinishWhenIdle waits for that write's completion,
//     successful or not.
#ifndef RISKPLAN_SERVER_PLAN_PLAN_CALL_STATE_H_
#define RISKPLAN_SERVER_PLAN_PLAN_CALL_STATE_H_

#include <cstdint>
#include <optional>
#include <string_view>
#include <utility>

#include "absl/time/time.h"
#include "core/base/check.h"
#include "grpcpp/support/status.h"
#include "server/plan/update_coalescer.h"

namespace riskplan::server {

enum class PlanCallPhase { kPlanning, kStopping, kFinalOffered, kFinishWhenIdle, kFinished };

// Why OnCancel ran: the client cancelled, or the call's deadline passed.
enum class CancelCause { kNone, kClient, kDeadline };

// The status a stream reports in its log line and metrics: the client's
// cancel or deadline when there was one (that is what the client saw), else
// `finish_status`, the status given to Finish(). PlanCallState's and
// FleetCallState's.
inline grpc::Status ReportedCallStatus(CancelCause cause, const grpc::Status& finish_status) {
  switch (cause) {
    case CancelCause::kDeadline:
      return grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED, "the call's deadline passed");
    case CancelCause::kClient:
      return grpc::Status(grpc::StatusCode::CANCELLED, "the client cancelled");
    case CancelCause::kNone:
      break;
  }
  return finish_status;
}

inline std::string_view PlanCallPhaseName(PlanCallPhase phase) {
  switch (phase) {
    case PlanCallPhase::kPlanning:
      return "kPlanning";
    case PlanCallPhase::kStopping:
      return "kStopping";
    case PlanCallPhase::kFinalOffered:
      return "kFinalOffered";
    case PlanCallPhase::kFinishWhenIdle:
      return "kFinishWhenIdle";
    case PlanCallPhase::kFinished:
      return "kFinished";
  }
  return "?";
}

template <typename T>
class PlanCallState {
 public:
  // What the caller must do next, in this order: stop the planner, schedule
  // a wake-up (call Poll() then), and start the write or finish the call. At
  // most one of `write` and `finish` is set; `finish` is set once per call.
  struct Step {
    bool stop_planner = false;           // cancel the planner's CancellationToken
    std::optional<absl::Time> wake_at;   // call Poll() at this time
    std::optional<T> write;              // start writing this message now
    std::optional<grpc::Status> finish;  // call Finish() with this status now
  };

  // Updates are written at least `min_update_interval` apart (UpdateCoalescer).
  explicit PlanCallState(absl::Duration min_update_interval) : coalescer_(min_update_interval) {}

  // A new improvement.
  Step Offer(T update, absl::Time now) {
    if (phase_ != PlanCallPhase::kPlanning) return {};
    return FromCoalescer(coalescer_.Offer(std::move(update), now));
  }

  // A wake-up asked for by a previous Step is due.
  Step Poll(absl::Time now) {
    if (phase_ != PlanCallPhase::kPlanning) return {};
    return FromCoalescer(coalescer_.Poll(now));
  }

  // The planner returned a result; `final_update` is the stream's last message.
  Step EndPlan(T final_update, absl::Time now) {
    switch (phase_) {
      case PlanCallPhase::kPlanning:
        phase_ = PlanCallPhase::kFinalOffered;
        return FromCoalescer(coalescer_.OfferFinal(std::move(final_update), now));
      case PlanCallPhase::kStopping:
        // Nobody is listening: end without writing.
        return FinishWhenIdle(grpc::Status(grpc::StatusCode::CANCELLED, "the call was cancelled"));
      default:
        return {};
    }
  }

  // End the call with `status` without a final message: it was refused
  // before planning, or planning failed. The first end decided wins.
  Step RequestFinish(grpc::Status status) {
    if (phase_ != PlanCallPhase::kPlanning && phase_ != PlanCallPhase::kStopping) return {};
    return FinishWhenIdle(std::move(status));
  }

  // The write in flight completed. REQUIRES: write_in_flight().
  Step WriteDone(absl::Time now) {
    RISKPLAN_DCHECK(coalescer_.write_in_flight());
    switch (phase_) {
      case PlanCallPhase::kFinishWhenIdle:
        // The end was waiting for this write only: nothing more is written
        // (an update the coalescer held is dropped), and nothing is in flight.
        coalescer_.OnWriteFailed();
        return FinishNow(finish_status_);
      case PlanCallPhase::kFinished:
        return {};  // cannot be (nothing is in flight): a no-op if it were
      default:
        return FromCoalescer(coalescer_.OnWriteDone(now));
    }
  }

  // The write in flight failed: the client is gone and nothing more can be
  // written. REQUIRES: write_in_flight().
  Step WriteFailed() {
    // Nothing is in flight any more: an end decided later must not wait for
    // this write's completion (it would wait for ever).
    coalescer_.OnWriteFailed();
    Step step;
    switch (phase_) {
      case PlanCallPhase::kPlanning:
        phase_ = PlanCallPhase::kStopping;  // Run() finishes once the planner returns
        break;
      case PlanCallPhase::kFinalOffered:
      case PlanCallPhase::kFinishWhenIdle:
        step = FinishNow(grpc::Status(grpc::StatusCode::CANCELLED, "the stream broke"));
        break;
      case PlanCallPhase::kStopping:
      case PlanCallPhase::kFinished:  // cannot be (nothing is in flight)
        break;
    }
    step.stop_planner = true;
    return step;
  }

  // gRPC's OnCancel: the client cancelled (kClient) or the deadline passed
  // (kDeadline).
  Step Cancel(CancelCause cause) {
    RISKPLAN_DCHECK(cause != CancelCause::kNone);
    cancel_cause_ = cause;
    if (phase_ == PlanCallPhase::kPlanning) phase_ = PlanCallPhase::kStopping;
    Step step;
    step.stop_planner = true;
    return step;
  }

  // The server is shutting down: the plan stops early and still sends its
  // final message (its end reason says SHUTDOWN).
  Step Shutdown() {
    stopped_by_shutdown_ = true;
    Step step;
    step.stop_planner = true;
    return step;
  }

  // The status the call reports in its log line and metrics (see
  // ReportedCallStatus): its cancel cause, else the status given to Finish().
  grpc::Status ReportedStatus() const { return ReportedCallStatus(cancel_cause_, finish_status_); }

  PlanCallPhase phase() const { return phase_; }
  CancelCause cancel_cause() const { return cancel_cause_; }
  bool stopped_by_shutdown() const { return stopped_by_shutdown_; }
  bool write_in_flight() const { return coalescer_.write_in_flight(); }
  // Updates replaced before being written.
  int64_t replaced() const { return coalescer_.replaced(); }

 private:
  Step FinishWhenIdle(grpc::Status status) {
    if (coalescer_.write_in_flight()) {
      phase_ = PlanCallPhase::kFinishWhenIdle;
      finish_status_ = std::move(status);
      return {};
    }
    return FinishNow(std::move(status));
  }

  Step FinishNow(grpc::Status status) {
    RISKPLAN_DCHECK(phase_ != PlanCallPhase::kFinished);
    phase_ = PlanCallPhase::kFinished;
    finish_status_ = status;
    Step step;
    step.finish = std::move(status);
    return step;
  }

  Step FromCoalescer(typename UpdateCoalescer<T>::Step c) {
    // The coalescer says "finish" only once the final message is written,
    // which it can only be after EndPlan.
    if (c.finish) {
      RISKPLAN_DCHECK(phase_ == PlanCallPhase::kFinalOffered);
      return FinishNow(grpc::Status::OK);
    }
    Step step;
    step.wake_at = c.wake_at;
    step.write = std::move(c.write);
    return step;
  }

  UpdateCoalescer<T> coalescer_;
  PlanCallPhase phase_ = PlanCallPhase::kPlanning;
  CancelCause cancel_cause_ = CancelCause::kNone;
  bool stopped_by_shutdown_ = false;
  grpc::Status finish_status_;  // kFinishWhenIdle: the status to come; kFinished: the one given
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_PLAN_PLAN_CALL_STATE_H_
