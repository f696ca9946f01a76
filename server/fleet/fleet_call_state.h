// FleetCallState: what a PlanFleet stream writes next and how it ends,
// written out as a state machine.
//
// A PlanFleet stream carries the messages of many missions, planned in groups
// on several pool threads, and can end in several ways that race with each
// other: every group ends, the client cancels or its deadline passes, a write
// fails because the client is gone, or the call is refused before it starts.
// Whatever the order, gRPC's Finish() must be called exactly once, only when
// no write is in flight, and only once no group can offer anything more.
// This class decides when, and which waiting message is written next.
//
// Pure logic, no gRPC calls, no locking, no clock (as PlanCallState, in
// server/plan/plan_call_state.h): FleetCall feeds it every event under its own
// mutex and performs the Step it gets back once the lock is released. T is
// the message type (v1::FleetUpdate; a string in the tests).
//
// The write discipline. At most one write is in flight. Final messages (a
// mission's result or its error) wait in order of arrival and are never
// dropped while the client is there. Improvements wait one per mission, a
// newer one replacing the older, and are written after every waiting final
// once the mission's minimum interval has passed since its previous
// improvement was written; one that is not yet due waits for the next event
// (there is no timer), and a mission's final replaces it.
//
// Phases (FleetCallPhase):
//   kCreated          initial; the request is being checked, nothing is written
//   kGoneBeforeStart  the client left (OnCancel) before Start: Start stops
//                     the call instead of streaming
//   kStreaming        started; finals and due improvements are written, and
//                     the call finishes OK once every group has ended and
//                     every final is written
//   kStopping         the client is gone (it cancelled, its deadline passed,
//                     or a write failed): the waiting messages are dropped,
//                     the planners are being stopped, and the call finishes
//                     CANCELLED once every group has ended and no write is
//                     in flight
//   kFinished         Finish() was started; terminal
// Beside the phase it keeps the cancel cause (what the log and metrics
// report), the groups still running, whether a write is in flight, the
// waiting messages, and the status Finish() is given.
//
// Transitions. "Done": no group is running and no write is in flight (in
// kStreaming, nor any final waiting). Every event not listed for a phase
// leaves everything unchanged and does nothing.
//   from              event             to                action
//   kCreated          Start(g, errors)  kStreaming        keep the errors as finals; the next
//                                                         write (or kFinished: Finish(OK) at
//                                                         once if g is 0 and there are none)
//   kCreated          Cancel(cause)     kGoneBeforeStart  record the cause
//   kCreated,         Reject(s)         kFinished         Finish(s)
//     kGoneBeforeStart
//   kGoneBeforeStart  Start(g, errors)  kStopping         stop the planners; drop the errors
//                                       kFinished         ... and Finish(CANCELLED) if g is 0
//   kStreaming        OfferFinal(m)     kStreaming        queue it, dropping m's waiting
//                                                         improvement; the next write
//   kStreaming        OfferImprovement  kStreaming        m's waiting improvement; the next write
//                       (m)
//   kStreaming        GroupEnded,       kStreaming        the next write
//                     WriteDone         kFinished         ... or Finish(OK) once done
//   kStreaming        Cancel(cause),    kStopping         record the cause; drop the waiting
//                     WriteFailed                         messages; stop the planners
//                                       kFinished         ... and Finish(CANCELLED) once done
//   kStopping         GroupEnded,       kStopping         nothing
//                     WriteDone,        kFinished         ... or Finish(CANCELLED) once done
//                     WriteFailed
//   kStopping,        Cancel(cause)     (same)            record the cause
//     kFinished
//
// Events: Start (the request is valid: g groups will plan, the invalid
// missions' errors are the first finals), Reject (the call is refused before
// Start), OfferFinal and OfferImprovement (from a group's planning thread),
// GroupEnded (a group has offered every result it will, or was dropped
// unplanned), WriteDone and WriteFailed (gRPC's OnWriteDone(ok) and
// OnWriteDone(!ok), so only with a write in flight, which never is in
// kFinished), Cancel (gRPC's OnCancel).
//
// Why these rules:
//   - Before Start the groups are not queued yet, so a cancel then has
//     nothing to stop: Start stops the call instead, and the scheduler drops
//     the groups it was about to queue.
//   - Once the client is gone nothing more is written, so nothing waits: the
//     call only waits for its groups, which hold it, and for the write in
//     flight, so that Finish() never races a write's completion.
//   - Offers are taken only while streaming: FleetCall counts the missions
//     ended (takes_offers()) only for the finals the state keeps, so a
//     cancelled mission is not counted as completed or failed.
//   - A failed write is recorded as the client's cancel (kClient) when
//     OnCancel has not said otherwise: the client is gone, and that is what
//     the log reports. OnCancel's cause replaces it, even after Finish():
//     the client saw its cancel or deadline, whatever the status given.
//   - A Cancel after Finish() stops nothing: Finish() comes only once every
//     group has ended, so no planner runs and no group waits.
#ifndef RISKPLAN_SERVER_FLEET_FLEET_CALL_STATE_H_
#define RISKPLAN_SERVER_FLEET_FLEET_CALL_STATE_H_

#include <cstddef>
#include <deque>
#include <map>
#include <optional>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/time/time.h"
#include "core/base/check.h"
#include "grpcpp/support/status.h"
#include "server/plan/plan_call_state.h"

namespace riskplan::server {

enum class FleetCallPhase { kCreated, kGoneBeforeStart, kStreaming, kStopping, kFinished };

inline std::string_view FleetCallPhaseName(FleetCallPhase phase) {
  switch (phase) {
    case FleetCallPhase::kCreated:
      return "kCreated";
    case FleetCallPhase::kGoneBeforeStart:
      return "kGoneBeforeStart";
    case FleetCallPhase::kStreaming:
      return "kStreaming";
    case FleetCallPhase::kStopping:
      return "kStopping";
    case FleetCallPhase::kFinished:
      return "kFinished";
  }
  return "?";
}

template <typename T>
class FleetCallState {
 public:
  // What the caller must do next, in this order: stop the planners, then
  // start the write or finish the call. At most one of `write` and `finish`
  // is set; `finish` is set once per call, `stop_planners` at most once.
  struct Step {
    bool stop_planners = false;          // cancel the call's token, drop its queued groups
    std::optional<T> write;              // start writing this message now
    std::optional<grpc::Status> finish;  // call Finish() with this status now
  };

  // The request is valid: `groups` groups will plan its missions, each
  // mission m's improvements at least `min_update_intervals[m]` apart, and
  // `first_finals` (the invalid missions' errors) are written first.
  Step Start(int groups, std::vector<absl::Duration> min_update_intervals,
             std::vector<T> first_finals, absl::Time now) {
    switch (phase_) {
      case FleetCallPhase::kCreated:
        phase_ = FleetCallPhase::kStreaming;
        groups_running_ = groups;
        improvement_sent_.assign(min_update_intervals.size(), absl::InfinitePast());
        min_update_interval_ = std::move(min_update_intervals);
        for (T& final_update : first_finals) finals_.push_back(std::move(final_update));
        return Next(now);
      case FleetCallPhase::kGoneBeforeStart: {
        // Nobody is listening: the groups are dropped as they are queued.
        phase_ = FleetCallPhase::kStopping;
        groups_running_ = groups;
        Step step = FinishIfStopped();
        step.stop_planners = true;
        return step;
      }
      default:
        return {};
    }
  }

  // The call is refused before Start with `status`. Once.
  Step Reject(grpc::Status status) {
    if (phase_ != FleetCallPhase::kCreated && phase_ != FleetCallPhase::kGoneBeforeStart) return {};
    return FinishNow(std::move(status));
  }

  // Mission `mission`'s result or error, its last message.
  Step OfferFinal(size_t mission, T final_update, absl::Time now) {
    if (phase_ != FleetCallPhase::kStreaming) return {};
    improvements_.erase(mission);  // the final carries the best trajectory
    finals_.push_back(std::move(final_update));
    return Next(now);
  }

  // A new improvement of mission `mission`.
  Step OfferImprovement(size_t mission, T update, absl::Time now) {
    if (phase_ != FleetCallPhase::kStreaming) return {};
    RISKPLAN_DCHECK(mission < min_update_interval_.size());
    improvements_[mission] = std::move(update);
    return Next(now);
  }

  // A group has offered every result it will (or was dropped unplanned).
  Step GroupEnded(absl::Time now) {
    if (phase_ != FleetCallPhase::kStreaming && phase_ != FleetCallPhase::kStopping) return {};
    RISKPLAN_DCHECK(groups_running_ > 0);
    --groups_running_;
    return Continue(now);
  }

  // The write in flight completed. REQUIRES: write_in_flight().
  Step WriteDone(absl::Time now) {
    RISKPLAN_DCHECK(in_flight_);
    in_flight_ = false;
    return Continue(now);
  }

  // The write in flight failed: the client is gone. REQUIRES: write_in_flight().
  Step WriteFailed() {
    RISKPLAN_DCHECK(in_flight_);
    in_flight_ = false;
    if (cancel_cause_ == CancelCause::kNone) cancel_cause_ = CancelCause::kClient;
    if (phase_ == FleetCallPhase::kStreaming) return Leave();
    if (phase_ == FleetCallPhase::kStopping) return FinishIfStopped();
    return {};
  }

  // gRPC's OnCancel: the client cancelled (kClient) or the deadline passed
  // (kDeadline).
  Step Cancel(CancelCause cause) {
    RISKPLAN_DCHECK(cause != CancelCause::kNone);
    cancel_cause_ = cause;
    if (phase_ == FleetCallPhase::kCreated) phase_ = FleetCallPhase::kGoneBeforeStart;
    if (phase_ == FleetCallPhase::kStreaming) return Leave();
    return {};
  }

  // The status the call reports in its log line and metrics (see
  // ReportedCallStatus): its cancel cause, else the status given to Finish().
  grpc::Status ReportedStatus() const { return ReportedCallStatus(cancel_cause_, finish_status_); }

  FleetCallPhase phase() const { return phase_; }
  // Offers are kept (and their missions counted as ended) only while streaming.
  bool takes_offers() const { return phase_ == FleetCallPhase::kStreaming; }
  CancelCause cancel_cause() const { return cancel_cause_; }
  bool write_in_flight() const { return in_flight_; }
  int groups_running() const { return groups_running_; }

 private:
  // After an event that may free the stream or end the call.
  Step Continue(absl::Time now) {
    switch (phase_) {
      case FleetCallPhase::kStreaming:
        return Next(now);
      case FleetCallPhase::kStopping:
        return FinishIfStopped();
      default:
        return {};
    }
  }

  // kStreaming: the next write, or Finish(OK) once done.
  Step Next(absl::Time now) {
    Step step;
    if (in_flight_) return step;
    step.write = TakeNextMessage(now);
    if (step.write.has_value()) {
      in_flight_ = true;
      return step;
    }
    // A waiting improvement that is not due yet does not hold the call: every
    // mission's final replaces it before its group ends.
    if (groups_running_ > 0) return step;
    return FinishNow(grpc::Status::OK);
  }

  // The oldest waiting final, else the first due improvement (by mission).
  std::optional<T> TakeNextMessage(absl::Time now) {
    if (!finals_.empty()) {
      T message = std::move(finals_.front());
      finals_.pop_front();
      return message;
    }
    for (auto it = improvements_.begin(); it != improvements_.end(); ++it) {
      const size_t m = it->first;
      if (now - improvement_sent_[m] < min_update_interval_[m]) continue;
      improvement_sent_[m] = now;
      T message = std::move(it->second);
      improvements_.erase(it);
      return message;
    }
    return std::nullopt;
  }

  // kStreaming: the client is gone.
  Step Leave() {
    phase_ = FleetCallPhase::kStopping;
    finals_.clear();
    improvements_.clear();
    Step step = FinishIfStopped();
    step.stop_planners = true;
    return step;
  }

  // kStopping: Finish(CANCELLED) once done.
  Step FinishIfStopped() {
    if (in_flight_ || groups_running_ > 0) return {};
    return FinishNow(grpc::Status(grpc::StatusCode::CANCELLED, "the call was cancelled"));
  }

  Step FinishNow(grpc::Status status) {
    RISKPLAN_DCHECK(phase_ != FleetCallPhase::kFinished);
    RISKPLAN_DCHECK(!in_flight_);
    phase_ = FleetCallPhase::kFinished;
    finish_status_ = status;
    Step step;
    step.finish = std::move(status);
    return step;
  }

  FleetCallPhase phase_ = FleetCallPhase::kCreated;
  CancelCause cancel_cause_ = CancelCause::kNone;
  int groups_running_ = 0;
  bool in_flight_ = false;
  std::deque<T> finals_;
  std::map<size_t, T> improvements_;                 // by mission, one each
  std::vector<absl::Duration> min_update_interval_;  // by mission
  std::vector<absl::Time> improvement_sent_;         // by mission: its last improvement written
  grpc::Status finish_status_;                       // kFinished: the status given
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_FLEET_FLEET_CALL_STATE_H_
