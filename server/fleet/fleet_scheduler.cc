#include "server/fleet/fleet_scheduler.h"

#include <optional>
#include <utility>

#include "server/fleet/fleet_group.h"

namespace riskplan::server {

FleetScheduler::FleetScheduler(const FleetEnv& env, int max_running_groups,
                               int64_t max_admitted_missions)
    : env_(env),
      max_admitted_missions_(max_admitted_missions),
      queue_(max_running_groups, max_admitted_missions) {}

FleetScheduler::~FleetScheduler() = default;

bool FleetScheduler::TryAdmit(int64_t missions) {
  absl::MutexLock lock(&mu_);
  return queue_.TryAdmit(missions);
}

void FleetScheduler::Unadmit(int64_t missions) {
  absl::MutexLock lock(&mu_);
  queue_.Unadmit(missions);
}

void FleetScheduler::Enqueue(const std::shared_ptr<FleetCall>& call,
                             std::shared_ptr<const FleetSpec> spec,
                             const std::vector<MissionGroup>& groups, const std::string& identity) {
  std::vector<std::shared_ptr<FleetGroup>> unplanned;
  {
    absl::MutexLock lock(&mu_);
    for (const MissionGroup& group : groups) {
      const uint64_t id = next_id_++;
      auto g = std::make_shared<FleetGroup>(id, call, spec, group, env_.models, env_.engine,
                                            env_.goal_trees);
      if (stopping_) {
        // The drain began after the call was let in: nothing more plans.
        queue_.Unadmit(static_cast<int64_t>(group.missions.size()));
        unplanned.push_back(std::move(g));
        continue;
      }
      groups_[id] = std::move(g);
      queue_.Push(id, identity, group.priority, static_cast<int64_t>(group.missions.size()));
    }
    UpdateGaugesLocked();
  }
  for (const std::shared_ptr<FleetGroup>& group : unplanned) {
    group->EndUnplanned();
    group->call()->GroupEnded();
  }
  // The client may have gone before its groups were queued (FleetCall's
  // cancel hook found none to drop).
  if (call->cancel_token().IsCancelled()) DropQueued(call.get());
  Pump();
}

void FleetScheduler::Pump() {
  for (;;) {
    std::shared_ptr<FleetGroup> group;
    {
      absl::MutexLock lock(&mu_);
      std::optional<uint64_t> next = queue_.Next();
      if (!next.has_value()) return;
      group = groups_.at(*next);
      // Every --max_running_plans slot is taken (PlanTrajectory's too): the
      // next release comes back here.
      if (!env_.active->TryAdmit(group)) return;
      queue_.Start(*next);
      UpdateGaugesLocked();
    }
    // Recorded before the task is queued: the task releases what was admitted.
    env_.metrics->PlanAdmitted(ServerMetrics::PlanKind::kFleetGroup);
    const bool queued = env_.pool->TrySubmit([this, group] {
      group->Run();
      Finished(group);
    });
    if (!queued) {
      // The pool refuses only while it is destroyed (the server is ending).
      group->EndUnplanned();
      Finished(group);
    }
  }
}

void FleetScheduler::Finished(const std::shared_ptr<FleetGroup>& group) {
  {
    absl::MutexLock lock(&mu_);
    queue_.Finish(group->id());
    groups_.erase(group->id());
    UpdateGaugesLocked();
  }
  env_.metrics->PlanReleased(ServerMetrics::PlanKind::kFleetGroup);
  // Starts the next group (the release listener) before the call is told.
  env_.active->Release(group.get());
  group->call()->GroupEnded();
}

std::vector<std::shared_ptr<FleetGroup>> FleetScheduler::TakeQueuedLocked(const FleetCall* call) {
  // Taken off the queue under the same lock that found them, so that Pump
  // cannot start one of them in between.
  std::vector<std::shared_ptr<FleetGroup>> taken;
  for (auto it = groups_.begin(); it != groups_.end();) {
    if ((call == nullptr || it->second->call().get() == call) && queue_.IsQueued(it->first)) {
      queue_.Finish(it->first);
      taken.push_back(std::move(it->second));
      it = groups_.erase(it);
    } else {
      ++it;
    }
  }
  UpdateGaugesLocked();
  return taken;
}

void FleetScheduler::DropQueued(const FleetCall* call) {
  std::vector<std::shared_ptr<FleetGroup>> dropped;
  {
    absl::MutexLock lock(&mu_);
    dropped = TakeQueuedLocked(call);
  }
  for (const std::shared_ptr<FleetGroup>& group : dropped) group->call()->GroupEnded();
}

void FleetScheduler::StopQueued() {
  std::vector<std::shared_ptr<FleetGroup>> dropped;
  {
    absl::MutexLock lock(&mu_);
    stopping_ = true;
    dropped = TakeQueuedLocked(nullptr);
  }
  for (const std::shared_ptr<FleetGroup>& group : dropped) {
    group->EndUnplanned();
    group->call()->GroupEnded();
  }
}

void FleetScheduler::UpdateGaugesLocked() {
  env_.metrics->SetFleetMissions(queue_.queued_missions(), queue_.running_missions());
}

}  // namespace riskplan::server
