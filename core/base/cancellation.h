// Cooperative cancellation, and the stop condition that long loops poll.
//
// Every loop whose length a request can choose (a trajectory's samples, a
// planner's edge, the ballistic integration of an impact table, a glide
// layer, a generation of the GA) polls a StopCondition every so often and
// returns early once it is reached: a budget, a client's deadline or the
// server's drain then ends the work within milliseconds instead of when the
// loop would have ended by itself.
#ifndef RISKPLAN_CORE_BASE_CANCELLATION_H_
#define RISKPLAN_CORE_BASE_CANCELLATION_H_

#include <atomic>
#include <chrono>
#include <optional>

namespace riskplan {

// Cooperative cancellation, shared between the caller and the worker.
// Thread-safe. Planners check it at least every few milliseconds.
class CancellationToken {
 public:
  void Cancel() { cancelled_.store(true, std::memory_order_relaxed); }
  bool IsCancelled() const { return cancelled_.load(std::memory_order_relaxed); }

 private:
  std::atomic<bool> cancelled_{false};
};

// Up to two cancellation tokens (e.g. a call's own and the server's drain)
// and a deadline on the steady clock; the condition is reached once either
// token is cancelled or the deadline has passed. A default-constructed one is
// never reached. A copyable value; the tokens must outlive every copy.
// Reached() is thread-safe.
class StopCondition {
 public:
  using Clock = std::chrono::steady_clock;

  StopCondition() = default;
  explicit StopCondition(const CancellationToken* token, const CancellationToken* other = nullptr,
                         std::optional<Clock::time_point> deadline = std::nullopt)
      : token_(token), other_(other), deadline_(deadline) {}

  bool Reached() const {
    if (token_ != nullptr && token_->IsCancelled()) return true;
    if (other_ != nullptr && other_->IsCancelled()) return true;
    return deadline_.has_value() && Clock::now() >= *deadline_;
  }

 private:
  const CancellationToken* token_ = nullptr;
  const CancellationToken* other_ = nullptr;
  std::optional<Clock::time_point> deadline_;
};

}  // namespace riskplan

#endif  // RISKPLAN_CORE_BASE_CANCELLATION_H_
