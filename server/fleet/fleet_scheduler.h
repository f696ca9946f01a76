// FleetScheduler: PlanFleet's mission groups from admission to their last
// result.
//
// A call's missions are admitted together (FleetQueue: they count against
// --max_admitted_missions until they end), then its groups
// (server/fleet/fleet_request.h) wait in the FleetQueue. A group plans once the
// queue picks it (fair share, priority, arrival) and a plan slot is free:
// at most --fleet_plan_slots groups at once, each holding one of
// ActivePlans' --max_running_plans slots (shared with PlanTrajectory, and
// counted in riskplan_running_plans) while it plans on the plan pool. Every
// slot released (a group's or a PlanTrajectory's) starts the next group.
//
// A group plans on its call's cancel token, offers each mission's
// improvements and result to its FleetCall, and tells it when it ends. A
// group whose call goes while it waits is dropped unplanned; at shutdown
// every waiting group ends at once with SHUTDOWN results (StopQueued), and
// ActivePlans::StopAll stops the planning ones.
//
// Thread-safe. Lock order: mu_, then ActivePlans' own (never the reverse:
// ActivePlans runs its release listener outside its lock).
#ifndef RISKPLAN_SERVER_FLEET_FLEET_SCHEDULER_H_
#define RISKPLAN_SERVER_FLEET_FLEET_SCHEDULER_H_

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "accel/risk_engine.h"
#include "server/fleet/fleet_call.h"
#include "server/fleet/fleet_queue.h"
#include "server/fleet/fleet_request.h"
#include "server/models/goal_tree_cache.h"
#include "server/observability/metrics.h"
#include "server/models/model_cache.h"
#include "server/plan/plan_call.h"
#include "server/plan/thread_pool.h"

namespace riskplan::server {

// What the groups need from the server; every pointer outlives the scheduler.
struct FleetEnv {
  RiskModelCache* models = nullptr;
  ServerMetrics* metrics = nullptr;
  ActivePlans* active = nullptr;
  ThreadPool* pool = nullptr;
  accel::RiskEngine* engine = nullptr;  // null: each planner's own evaluator
  GoalTreeCache* goal_trees = nullptr;  // null: shared trees are built per request
};

class FleetGroup;

class FleetScheduler {
 public:
  // REQUIRES: max_running_groups >= 1, max_admitted_missions >= 1.
  FleetScheduler(const FleetEnv& env, int max_running_groups, int64_t max_admitted_missions);
  ~FleetScheduler();

  // Admits `missions` missions of one call; false (nothing counted) when
  // they would pass --max_admitted_missions.
  bool TryAdmit(int64_t missions);
  // Gives back admitted missions that will not be queued (invalid ones).
  void Unadmit(int64_t missions);
  int64_t max_admitted_missions() const { return max_admitted_missions_; }

  // Queues the groups of `call` (Start()ed with `spec` and groups.size())
  // for the fair share of `identity`, and starts what can start.
  // REQUIRES: their missions were admitted.
  void Enqueue(const std::shared_ptr<FleetCall>& call, std::shared_ptr<const FleetSpec> spec,
               const std::vector<MissionGroup>& groups, const std::string& identity);
  // Drops the waiting groups of `call` (its client went).
  void DropQueued(const FleetCall* call);
  // Ends every waiting group with SHUTDOWN results (the server's drain),
  // and every group enqueued from now on, unplanned.
  void StopQueued();
  // Starts waiting groups while group and plan slots are free.
  void Pump();

 private:
  // A running group ended: takes it off the queue's books, frees its slot,
  // tells its call.
  void Finished(const std::shared_ptr<FleetGroup>& group);
  void UpdateGaugesLocked() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Removes the waiting groups of `call` (null: of every call).
  std::vector<std::shared_ptr<FleetGroup>> TakeQueuedLocked(const FleetCall* call)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  const FleetEnv env_;
  const int64_t max_admitted_missions_;
  absl::Mutex mu_;
  FleetQueue queue_ ABSL_GUARDED_BY(mu_);
  std::map<uint64_t, std::shared_ptr<FleetGroup>> groups_ ABSL_GUARDED_BY(mu_);  // queued, running
  uint64_t next_id_ ABSL_GUARDED_BY(mu_) = 1;
  bool stopping_ ABSL_GUARDED_BY(mu_) = false;  // StopQueued was called
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_FLEET_FLEET_SCHEDULER_H_
