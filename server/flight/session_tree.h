// SessionTree: the goal tree a Fly session keeps for its whole flight
// (docs/in-flight.md, "The tree kept alive").
//
// RISK_RRT_STAR grows its tree from the goal, and the aircraft is only a start
// connected to it, so every plan of a session from its moving commit point is
// a new query into the same tree: SharedGoalTreePlanner with one mission,
// beginning from the tree the previous plan left (SharedTreeOptions::
// initial_tree). The commit point is connected to the tree as it stands
// before any new sample, so a replan has a remainder as soon as a kept
// branch reaches it, and the tree's refinement carries over from plan to plan.
//
// When the model changes only by closed cells (a zone added: the session's
// map with its zones closed, the same wind and parameters), the tree is
// pruned for the new model (PruneGoalTree: the nodes whose edges a zone cuts
// go, with their subtrees; every kept risk is exact). A zone removed only
// opens cells: every kept edge stays admissible, and the pruning check finds
// nothing to cut. A new wind, new parameters or another map change every
// risk: the tree is dropped (as by Reset()) and the next plan grows one from
// the goal again. Models count as the same but for closed cells when their
// maps share their layers (RiskMap::SharesLayersWith: one made from the other
// by WithNoFly) and every model parameter is equal.
//
// Bounded: a tree past half the plan's max_nodes is dropped before the next
// plan (a tree at max_nodes would end every plan at once), so a session holds
// at most max_nodes x about 130 bytes of tree.
//
// With flight limits (PlanOptions::limits active) or another algorithm the
// plan is MakePlanner's, from scratch, as a plan request's would be.
//
// Not thread-safe: one session, one thread at a time.
#ifndef RISKPLAN_SERVER_FLIGHT_SESSION_TREE_H_
#define RISKPLAN_SERVER_FLIGHT_SESSION_TREE_H_

#include <cstdint>
#include <memory>

#include "absl/status/statusor.h"
#include "core/base/cancellation.h"
#include "core/planners/goal_tree_repair.h"
#include "core/planners/planner.h"
#include "core/planners/shared_goal_tree.h"
#include "core/risk/risk_evaluator.h"

namespace riskplan::server {

struct SessionTreeStats {
  int64_t plans = 0;              // plans made
  int64_t from_tree = 0;          // ... of which began from a kept tree
  int64_t resets = 0;             // trees dropped (Reset, the size bound, a closed goal)
  int64_t tree_nodes = 0;         // nodes of the tree kept now
  GoalTreePruneStats last_prune;  // of the latest pruning
};

class SessionTree {
 public:
  // Forgets the tree.
  void Reset();

  // A plan from `from` to `goal` under `model` with `options` (its budget and
  // seed; the seed counts only for a tree grown from the goal, after which
  // the tree's generations give the random streams). `evaluator` may be null
  // (the planner's own). `on_improvement` sees every improvement.
  absl::StatusOr<PlanResult> Plan(const std::shared_ptr<const RiskModel>& model,
                                  PlannerAlgorithm algorithm, const Pose& from, const Pose& goal,
                                  const PlanOptions& options, RiskEvaluator* evaluator,
                                  const CancellationToken& cancel,
                                  const ImprovementCallback& on_improvement);

  const SessionTreeStats& stats() const { return stats_; }

 private:
  std::shared_ptr<const GoalTree> tree_;
  std::shared_ptr<const RiskModel> tree_model_;  // the model tree_ is valid for
  SessionTreeStats stats_;
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_FLIGHT_SESSION_TREE_H_
