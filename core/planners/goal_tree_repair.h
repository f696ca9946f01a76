// Keeping a goal tree (core/planners/shared_goal_tree.h) alive when the
// admissible space shrinks: a temporary no-fly zone, or a glide layer that
// rose around one (server/flight/, docs/in-flight.md).
//
// Closing cells changes no configuration risk (spec sections 3-5 read the
// density, shelter and terrain, never the no-fly layer); it only makes some
// configurations inadmissible (section 6). So every edge of a tree whose
// samples all stay admissible keeps its exact piece risk, and every node whose
// path to the goal keeps all its edges keeps its exact R(node): the tree
// without the rest is a tree the planner could have grown under the new model,
// and a plan may begin from it (SharedTreeOptions::initial_tree) instead of
// from the goal alone. A node is dropped when its own pose or a midpoint of
// its edge to its parent (the samples RISK_RRT_STAR checks when it adds the
// edge) is not admissible under the new model, and with it every node below
// it. What is dropped is not rewired (RRTx's orphan repair): the plan that
// begins from the pruned tree grows into the gap again, and a route a zone
// removal should give back comes from the session's earlier remainders.
//
// Not for a change of wind, map or model parameters: those change the risks
// themselves, and a tree grown under other risks must be grown again.
#ifndef RISKPLAN_CORE_PLANNERS_GOAL_TREE_REPAIR_H_
#define RISKPLAN_CORE_PLANNERS_GOAL_TREE_REPAIR_H_

#include <cstdint>
#include <optional>

#include "core/base/cancellation.h"
#include "core/planners/shared_goal_tree.h"
#include "core/risk/risk_model.h"

namespace riskplan {

// A rectangle of the plane (map coordinates, m) outside which the new model
// is no stricter than the tree's: only edges that may pass through it are
// checked (an edge of length L lies within L of both its ends).
struct PruneRegion {
  double x_min = 0.0;
  double y_min = 0.0;
  double x_max = 0.0;
  double y_max = 0.0;
};

// Where `after` is stricter than `before` (a cell closed, or its glide
// altitude raised), as the bounding box of those cells' squares, or nullopt
// when it is nowhere stricter (then no tree edge can have become
// inadmissible). REQUIRES: both models' maps share their layers but for the
// no-fly cells (RiskMap::SharesLayersWith) and their parameters are equal.
std::optional<PruneRegion> StricterRegion(const RiskModel& before, const RiskModel& after);

struct GoalTreePruneStats {
  int64_t kept = 0;             // nodes of the pruned tree, the goal included
  int64_t cut_edges = 0;        // nodes whose own pose or edge is inadmissible
  int64_t orphaned = 0;         // nodes dropped below a cut edge
  int64_t checked_samples = 0;  // configurations checked for admissibility
  int64_t skipped_edges = 0;    // edges wholly outside the region, not checked
};

// `tree` without every node that is not admissible, or whose edge to its
// parent or any ancestor's is not, under `model` (the tree's model with
// cells closed; the caller keeps that promise). Nodes keep their order (the
// goal stays node 0) and are renumbered; goal, params, seed and generation
// are kept. When the goal itself is not admissible, the result has no nodes.
// Cancelled once `stop` is reached (checked between nodes). With `region`,
// only nodes and edges that may reach into it are checked (the caller
// promises the model is nowhere else stricter than the tree's: StricterRegion).
absl::StatusOr<GoalTree> PruneGoalTree(const GoalTree& tree, const RiskModel& model,
                                       const StopCondition& stop = {},
                                       GoalTreePruneStats* stats = nullptr,
                                       const std::optional<PruneRegion>& region = std::nullopt);

}  // namespace riskplan

#endif  // RISKPLAN_CORE_PLANNERS_GOAL_TREE_REPAIR_H_
