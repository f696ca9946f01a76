#include "server/fleet/fleet_queue.h"

#include <tuple>

#include "core/base/check.h"

namespace riskplan::server {

bool FleetQueue::TryAdmit(int64_t missions) {
  if (missions < 0 || missions > max_admitted_missions_ - admitted_missions_) return false;
  admitted_missions_ += missions;
  return true;
}

void FleetQueue::Unadmit(int64_t missions) {
  RISKPLAN_DCHECK(missions >= 0 && missions <= admitted_missions_);
  admitted_missions_ -= missions;
}

void FleetQueue::Push(uint64_t id, const std::string& identity, int priority, int64_t missions) {
  RISKPLAN_DCHECK(!groups_.contains(id));
  groups_[id] = Group{.identity = identity, .priority = priority, .missions = missions};
  ++groups_by_identity_[identity];
  arrival_[arrivals_++] = id;
  queued_missions_ += missions;
}

std::optional<uint64_t> FleetQueue::Next() const {
  if (running_groups_ >= max_running_groups_) return std::nullopt;
  // A scan of the waiting groups: there are at most max_admitted_missions of
  // them (a thousand or so), and a slot frees only when a plan ends.
  std::optional<uint64_t> best;
  // (groups its identity is planning, when that identity last started one,
  // -priority); ties: the earlier arrival, first in arrival_.
  using Key = std::tuple<int, uint64_t, int>;
  Key best_key;
  for (const auto& [arrival, id] : arrival_) {
    const Group& g = groups_.at(id);
    auto last = last_start_.find(g.identity);
    const Key key{RunningOf(g.identity), last == last_start_.end() ? 0 : last->second,
                  -g.priority};
    if (!best.has_value() || key < best_key) {
      best = id;
      best_key = key;
    }
  }
  return best;
}

void FleetQueue::Start(uint64_t id) {
  auto it = groups_.find(id);
  RISKPLAN_DCHECK(it != groups_.end() && !it->second.running);
  for (auto a = arrival_.begin(); a != arrival_.end(); ++a) {
    if (a->second == id) {
      arrival_.erase(a);
      break;
    }
  }
  Group& g = it->second;
  g.running = true;
  ++running_groups_;
  ++running_by_identity_[g.identity];
  last_start_[g.identity] = ++starts_;
  queued_missions_ -= g.missions;
  running_missions_ += g.missions;
}

bool FleetQueue::Finish(uint64_t id) {
  auto it = groups_.find(id);
  if (it == groups_.end()) return false;
  const Group& g = it->second;
  if (g.running) {
    --running_groups_;
    if (--running_by_identity_[g.identity] == 0) running_by_identity_.erase(g.identity);
    running_missions_ -= g.missions;
  } else {
    for (auto a = arrival_.begin(); a != arrival_.end(); ++a) {
      if (a->second == id) {
        arrival_.erase(a);
        break;
      }
    }
    queued_missions_ -= g.missions;
  }
  admitted_missions_ -= g.missions;
  if (--groups_by_identity_[g.identity] == 0) {
    groups_by_identity_.erase(g.identity);
    last_start_.erase(g.identity);
  }
  groups_.erase(it);
  return true;
}

bool FleetQueue::IsQueued(uint64_t id) const {
  auto it = groups_.find(id);
  return it != groups_.end() && !it->second.running;
}

int FleetQueue::RunningOf(const std::string& identity) const {
  auto it = running_by_identity_.find(identity);
  return it == running_by_identity_.end() ? 0 : it->second;
}

}  // namespace riskplan::server
