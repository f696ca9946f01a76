// One thread that runs small callbacks at given times.
//
// Used to send a withheld plan update once PlanRequest.min_update_interval_ms
// has passed when no newer event would send it. Callbacks run on the timer's
// thread, in order of their due time, and must be short and non-blocking.
#ifndef RISKPLAN_SERVER_PLAN_TIMER_QUEUE_H_
#define RISKPLAN_SERVER_PLAN_TIMER_QUEUE_H_

#include <cstdint>
#include <functional>
#include <map>
#include <thread>
#include <utility>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"

namespace riskplan::server {

class TimerQueue {
 public:
  TimerQueue();
  // Drops the callbacks not yet due and joins the thread.
  ~TimerQueue();

  TimerQueue(const TimerQueue&) = delete;
  TimerQueue& operator=(const TimerQueue&) = delete;

  // Runs `callback` on the timer's thread at `when` (at once when `when` has
  // passed). Callbacks hold their own references: the queue does not know the
  // objects they touch. Thread-safe.
  void Schedule(absl::Time when, std::function<void()> callback);

  // Callbacks not yet run. Thread-safe.
  size_t pending() const;

 private:
  void Loop();

  mutable absl::Mutex mu_;
  // Keyed by (due time, insertion number) so equal times keep their order.
  std::map<std::pair<absl::Time, uint64_t>, std::function<void()>> timers_ ABSL_GUARDED_BY(mu_);
  uint64_t next_id_ ABSL_GUARDED_BY(mu_) = 0;
  bool stopping_ ABSL_GUARDED_BY(mu_) = false;
  std::thread thread_;
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_PLAN_TIMER_QUEUE_H_
