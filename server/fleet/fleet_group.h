// FleetGroup: one group of PlanFleet missions (server/fleet/fleet_request.h) as it
// plans on a plan-pool thread: RISK_RRT_STAR missions on one shared goal
// tree (SharedGoalTreePlanner), or one mission with its own planner, exactly
// as PlanTrajectory would plan it. Each mission's improvements and its one
// result go to the group's FleetCall; errors are the mission's own, with
// its field path (MissionError).
#ifndef RISKPLAN_SERVER_FLEET_FLEET_GROUP_H_
#define RISKPLAN_SERVER_FLEET_FLEET_GROUP_H_

#include <cstdint>
#include <memory>
#include <vector>

#include "accel/risk_engine.h"
#include "server/fleet/fleet_call.h"
#include "server/fleet/fleet_request.h"
#include "server/models/goal_tree_cache.h"
#include "server/models/model_cache.h"
#include "server/plan/plan_call.h"

namespace riskplan::server {

class FleetGroup final : public ActivePlan {
 public:
  // `models`, `engine` (may be null) and `goal_trees` (may be null: no
  // cache, each shared group grows its tree from the goal) outlive the group.
  FleetGroup(uint64_t id, std::shared_ptr<FleetCall> call, std::shared_ptr<const FleetSpec> spec,
             MissionGroup group, RiskModelCache* models, accel::RiskEngine* engine,
             GoalTreeCache* goal_trees = nullptr)
      : id_(id),
        call_(std::move(call)),
        spec_(std::move(spec)),
        group_(std::move(group)),
        models_(models),
        engine_(engine),
        goal_trees_(goal_trees) {}

  // Plans every mission and offers its result; a call already cancelled
  // plans nothing. Never throws: an exception (std::bad_alloc) becomes the
  // error of every mission not yet reported.
  void Run();
  // Offers a result without trajectory (end reason SHUTDOWN) for every
  // mission: the group was dropped by the server's drain before it planned.
  // The call's other groups are not stopped.
  void EndUnplanned();
  // Stops the call's planners (ActivePlan).
  void StopForShutdown() override { call_->StopForShutdown(); }

  uint64_t id() const { return id_; }
  const std::shared_ptr<FleetCall>& call() const { return call_; }
  const MissionGroup& group() const { return group_; }

 private:
  void PlanAlone(size_t mission);
  void PlanShared();
  void Offer(size_t mission, const absl::StatusOr<PlanResult>& result);
  std::unique_ptr<RiskEvaluator> NewEvaluator(const PlanOptions& options, double max_time_s) const;

  const uint64_t id_;
  const std::shared_ptr<FleetCall> call_;
  const std::shared_ptr<const FleetSpec> spec_;
  const MissionGroup group_;
  RiskModelCache* const models_;
  accel::RiskEngine* const engine_;
  GoalTreeCache* const goal_trees_;
  std::vector<bool> reported_;  // by position in group_.missions; Run's thread only
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_FLEET_FLEET_GROUP_H_
