// The write discipline of a plan stream: at most one message in flight, the
// newest update replaces an unsent one, a minimum interval between updates,
// and a final message that is never delayed or dropped.
//
// Pure logic, no gRPC: the caller (PlanCall) serialises every call under its
// own mutex, performs the Step it gets back (start a write, schedule a wake-up,
// finish the call), and reports write completions and wake-ups.
//
// Sequence of a stream: Offer()* ... OfferFinal() once; OnWriteDone() after
// every write it was told to start; Poll() when a wake-up it asked for is due.
#ifndef RISKPLAN_SERVER_PLAN_UPDATE_COALESCER_H_
#define RISKPLAN_SERVER_PLAN_UPDATE_COALESCER_H_

#include <cstdint>
#include <optional>
#include <utility>

#include "absl/time/time.h"
#include "core/base/check.h"

namespace riskplan::server {

template <typename T>
class UpdateCoalescer {
 public:
  // What the caller must do next. At most one of `write` and `finish` is set.
  struct Step {
    std::optional<T> write;             // start writing this message now
    bool is_final = false;              // `write` is the final message
    bool finish = false;                // the final message was written: end the call
    std::optional<absl::Time> wake_at;  // call Poll() at this time
  };

  // Updates are sent at least `min_interval` apart (measured from the start of
  // the previous write); zero sends as fast as writes complete.
  explicit UpdateCoalescer(absl::Duration min_interval) : min_interval_(min_interval) {}

  // A newer update. It replaces an update still waiting to be sent.
  Step Offer(T update, absl::Time now) {
    if (final_offered_) return {};
    if (pending_.has_value()) ++replaced_;
    pending_ = std::move(update);
    return Next(now);
  }

  // The last message of the stream. It replaces an update still waiting (the
  // final message carries the best result), and it is sent as soon as the
  // write in flight, if any, completes, whatever the minimum interval.
  Step OfferFinal(T final_update, absl::Time now) {
    if (final_offered_) return {};
    final_offered_ = true;
    if (pending_.has_value()) {
      ++replaced_;
      pending_.reset();
    }
    final_ = std::move(final_update);
    return Next(now);
  }

  // The write in flight completed (successfully: on a failed write the caller
  // stops writing altogether). REQUIRES: write_in_flight().
  Step OnWriteDone(absl::Time now) {
    RISKPLAN_DCHECK(in_flight_);
    in_flight_ = false;
    if (final_written_) {
      Step step;
      step.finish = true;
      return step;
    }
    return Next(now);
  }

  // The write in flight failed (the client is gone): nothing more will be
  // written, and nothing is in flight any more. REQUIRES: write_in_flight().
  void OnWriteFailed() {
    RISKPLAN_DCHECK(in_flight_);
    in_flight_ = false;
  }

  // A wake-up asked for by a previous Step is due.
  Step Poll(absl::Time now) {
    wake_scheduled_.reset();
    return Next(now);
  }

  // Updates replaced before being sent.
  int64_t replaced() const { return replaced_; }
  bool write_in_flight() const { return in_flight_; }
  bool final_offered() const { return final_offered_; }
  bool final_written() const { return final_written_; }

 private:
  Step Next(absl::Time now) {
    Step step;
    if (in_flight_) return step;
    if (final_.has_value()) {
      step.write = std::move(final_);
      final_.reset();
      step.is_final = true;
      final_written_ = true;
      in_flight_ = true;
      return step;
    }
    if (!pending_.has_value()) return step;
    const absl::Time due = last_write_start_ + min_interval_;
    if (!has_written_ || now >= due) {
      step.write = std::move(pending_);
      pending_.reset();
      in_flight_ = true;
      has_written_ = true;
      last_write_start_ = now;
      return step;
    }
    // Withheld: make sure a wake-up is due by then (one at a time).
    if (!wake_scheduled_.has_value() || *wake_scheduled_ > due) {
      wake_scheduled_ = due;
      step.wake_at = due;
    }
    return step;
  }

  const absl::Duration min_interval_;
  std::optional<T> pending_;
  std::optional<T> final_;
  bool in_flight_ = false;
  bool has_written_ = false;
  bool final_offered_ = false;
  bool final_written_ = false;
  absl::Time last_write_start_ = absl::InfinitePast();
  std::optional<absl::Time> wake_scheduled_;
  int64_t replaced_ = 0;
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_PLAN_UPDATE_COALESCER_H_
