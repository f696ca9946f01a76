// EventLog: the numbered events of one gateway session (a plan, a mission,
// a flight), kept so that any number of viewers can watch it and a
// reconnecting viewer resumes after the last event it saw. Bounded: past
// max_events or max_bytes the oldest events are dropped (never the newest,
// and the terminal event is always kept). Thread-safe.
#ifndef RISKPLAN_WEB_EVENT_LOG_H_
#define RISKPLAN_WEB_EVENT_LOG_H_

#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"

namespace riskplan::web {

// One event as sent to viewers (the types are the session's: web/sse.h
// frames them, docs/web.md lists them).
struct PlanEvent {
  uint64_t id = 0;  // 1, 2, 3, ... within the session
  std::string type;
  // JSON, one line. Shared, never copied: an event of a long trajectory is
  // tens of kilobytes, and every viewer sends the same one.
  std::shared_ptr<const std::string> data;
};

// Bounds of a session's memory.
struct PlanEventLimits {
  // Events kept; past either bound the oldest are dropped (the newest
  // improvement always holds the whole best trajectory, and the terminal
  // event is always kept), so a viewer resuming from an id older than the
  // oldest kept gets what is left.
  size_t max_events = 2000;
  size_t max_bytes = size_t{8} << 20;
};

class EventLog {
 public:
  explicit EventLog(PlanEventLimits limits) : limits_(limits) {}

  // Appends an event; `terminal`: the session's last (nothing is appended
  // after it). False, and nothing appended, when the log has ended.
  bool Append(const std::string& type, std::string data, bool terminal);

  // Waits until there is an event with an id above `after_id`, the log has
  // ended, Stop() was called, or `deadline` passes; then appends the kept
  // events with ids above `after_id` to `*out`, oldest first, stopping once
  // their data reach `max_bytes` (always at least one), so that a viewer
  // catching up on a long session sends it in pieces. Returns true when no
  // event will ever come after those: the log ended and `*out` ends with its
  // last event (or it ended before `after_id`), or it is stopped.
  bool WaitForEvents(uint64_t after_id, absl::Time deadline, std::vector<PlanEvent>* out,
                     size_t max_bytes = size_t{256} << 10);

  // Wakes every waiting viewer for good (the gateway is shutting down).
  void Stop();

  bool ended() const;
  uint64_t last_event_id() const;
  // Ids of the oldest and newest events kept (0, 0 when none).
  std::pair<uint64_t, uint64_t> kept_range() const;

 private:
  const PlanEventLimits limits_;
  mutable absl::Mutex mu_;
  std::deque<PlanEvent> events_ ABSL_GUARDED_BY(mu_);
  size_t bytes_ ABSL_GUARDED_BY(mu_) = 0;
  uint64_t last_id_ ABSL_GUARDED_BY(mu_) = 0;
  bool ended_ ABSL_GUARDED_BY(mu_) = false;
  bool stopped_ ABSL_GUARDED_BY(mu_) = false;
};

}  // namespace riskplan::web

#endif  // RISKPLAN_WEB_EVENT_LOG_H_
