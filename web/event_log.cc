#include "web/event_log.h"

namespace riskplan::web {

bool EventLog::Append(const std::string& type, std::string data, bool terminal) {
  absl::MutexLock lock(&mu_);
  if (ended_) return false;  // nothing after the terminal event
  PlanEvent event{++last_id_, type, std::make_shared<const std::string>(std::move(data))};
  bytes_ += event.data->size();
  events_.push_back(std::move(event));
  ended_ = terminal;
  // Drop the oldest events beyond the bounds; never the newest (the best
  // trajectory, or the terminal event).
  while (events_.size() > 1 &&
         (events_.size() > limits_.max_events || bytes_ > limits_.max_bytes)) {
    bytes_ -= events_.front().data->size();
    events_.pop_front();
  }
  return true;
}

bool EventLog::WaitForEvents(uint64_t after_id, absl::Time deadline, std::vector<PlanEvent>* out,
                             size_t max_bytes) {
  absl::MutexLock lock(&mu_);
  auto ready = [this, after_id]() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    return last_id_ > after_id || ended_ || stopped_;
  };
  mu_.AwaitWithDeadline(absl::Condition(&ready), deadline);
  if (stopped_) return true;
  size_t bytes = 0;
  bool all = true;
  for (const PlanEvent& e : events_) {
    if (e.id <= after_id) continue;
    if (bytes >= max_bytes) {
      all = false;
      break;
    }
    out->push_back(e);
    bytes += e.data->size();
  }
  return all && ended_;
}

void EventLog::Stop() {
  absl::MutexLock lock(&mu_);
  stopped_ = true;
}

bool EventLog::ended() const {
  absl::MutexLock lock(&mu_);
  return ended_;
}

uint64_t EventLog::last_event_id() const {
  absl::MutexLock lock(&mu_);
  return last_id_;
}

std::pair<uint64_t, uint64_t> EventLog::kept_range() const {
  absl::MutexLock lock(&mu_);
  if (events_.empty()) return {0, 0};
  return {events_.front().id, events_.back().id};
}

}  // namespace riskplan::web
