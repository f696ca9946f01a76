#include "server/plan/timer_queue.h"

namespace riskplan::server {

TimerQueue::TimerQueue() : thread_([this] { Loop(); }) {}

// Callbacks not yet due are dropped, releasing the references they hold: the
// service destroys the timer after gRPC has shut down and the pools have
// drained, so no call is left to write to.
TimerQueue::~TimerQueue() {
  {
    absl::MutexLock lock(&mu_);
    stopping_ = true;
  }
  thread_.join();
}

void TimerQueue::Schedule(absl::Time when, std::function<void()> callback) {
  absl::MutexLock lock(&mu_);
  timers_.emplace(std::make_pair(when, next_id_++), std::move(callback));
}

size_t TimerQueue::pending() const {
  absl::MutexLock lock(&mu_);
  return timers_.size();
}

void TimerQueue::Loop() {
  absl::MutexLock lock(&mu_);
  while (!stopping_) {
    // Sleep until the earliest timer is due, waking early when a timer is
    // added (it may be due sooner) or on shutdown: both change next_id_ or
    // stopping_, which the condition reads.
    const uint64_t seen_id = next_id_;
    struct Wake {
      const TimerQueue* queue;
      uint64_t seen_id;
    } wake{this, seen_id};
    const absl::Condition changed(
        +[](Wake* w) { return w->queue->stopping_ || w->queue->next_id_ != w->seen_id; }, &wake);
    if (timers_.empty()) {
      mu_.Await(changed);
      continue;
    }
    const absl::Time due = timers_.begin()->first.first;
    if (absl::Now() < due) {
      mu_.AwaitWithDeadline(changed, due);
      continue;
    }
    // Run without the lock: a callback takes its call's lock (PlanCall::
    // OnTimer) and may schedule another timer, which takes mu_.
    std::function<void()> callback = std::move(timers_.begin()->second);
    timers_.erase(timers_.begin());
    mu_.Unlock();
    callback();
    mu_.Lock();
  }
}

}  // namespace riskplan::server
