#include "core/planners/goal_tree_repair.h"

#include <vector>

#include "absl/strings/str_format.h"
#include "core/flight/piece_risk.h"
#include "core/flight/trajectory_piece.h"

namespace riskplan {
namespace {

enum class NodeState : uint8_t { kUnknown, kVisiting, kKept, kDropped };

}  // namespace

absl::StatusOr<GoalTree> PruneGoalTree(const GoalTree& tree, const RiskModel& model,
                                       const StopCondition& stop, GoalTreePruneStats* stats) {
  GoalTreePruneStats local;
  GoalTreePruneStats& st = stats != nullptr ? *stats : local;
  st = GoalTreePruneStats{};
  GoalTree out;
  out.goal = tree.goal;
  out.params = tree.params;
  out.seed = tree.seed;
  out.generation = tree.generation;
  const int64_t n = static_cast<int64_t>(tree.nodes.size());
  if (n == 0) return out;
  if (tree.nodes[0].parent != -1) {
    return absl::InvalidArgumentError("goal tree node 0 (the goal) has a parent");
  }
  const ModelParams& mp = model.params();
  const auto admissible = [&](const Pose& q) {
    ++st.checked_samples;
    return model.CheckConfiguration(q) == ViolationKind::kNone;
  };
  // Whether node k's own pose and the midpoints of its edge to its parent are
  // admissible (the edge as RISK_RRT_STAR adds it: from the node to its parent).
  const auto edge_holds = [&](int64_t k) {
    const GoalTreeNode& node = tree.nodes[k];
    if (!admissible(node.pose)) return false;
    if (node.parent < 0) return true;
    const PieceRisk rule(TrajectoryPiece::Manoeuvre(node.pose, tree.nodes[node.parent].pose,
                                                    mp.GroundTurnRadius(), mp.GroundClimbAngle()),
                         mp.sample_step_m, mp);
    for (int64_t i = 0; i < rule.parts(); ++i) {
      if (!admissible(rule.Midpoint(i))) return false;
    }
    return true;
  };
  std::vector<NodeState> state(n, NodeState::kUnknown);
  std::vector<int64_t> chain;
  for (int64_t k = 0; k < n; ++k) {
    if (stop.Reached()) return absl::CancelledError("pruning the goal tree: stopped");
    if (state[k] != NodeState::kUnknown) continue;
    // Walk up to the first node whose state is known (or the goal), then
    // settle the chain from the top: a node is kept when its parent is and
    // its own edge holds.
    chain.clear();
    int64_t up = k;
    while (up >= 0 && state[up] == NodeState::kUnknown) {
      state[up] = NodeState::kVisiting;
      chain.push_back(up);
      const int32_t parent = tree.nodes[up].parent;
      if (parent >= n || (parent < 0 && up != 0)) {
        return absl::InvalidArgumentError(absl::StrFormat(
            "goal tree node %d has parent %d: not a tree of %d nodes rooted at node 0", up, parent,
            n));
      }
      up = parent;
    }
    if (up >= 0 && state[up] == NodeState::kVisiting) {
      return absl::InvalidArgumentError(
          absl::StrFormat("goal tree node %d lies on a cycle of parents", up));
    }
    bool parent_kept = up < 0 || state[up] == NodeState::kKept;
    for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
      if (!parent_kept) {
        state[*it] = NodeState::kDropped;
        ++st.orphaned;
        continue;
      }
      if (edge_holds(*it)) {
        state[*it] = NodeState::kKept;
      } else {
        state[*it] = NodeState::kDropped;
        ++st.cut_edges;
        parent_kept = false;
      }
    }
  }
  if (state[0] != NodeState::kKept) return out;  // the goal is closed: nothing to begin from
  std::vector<int32_t> renumbered(n, -1);
  for (int64_t k = 0, m = 0; k < n; ++k) {
    if (state[k] == NodeState::kKept) renumbered[k] = static_cast<int32_t>(m++);
  }
  for (int64_t k = 0; k < n; ++k) {
    if (state[k] != NodeState::kKept) continue;
    GoalTreeNode node = tree.nodes[k];
    if (node.parent >= 0) node.parent = renumbered[node.parent];
    out.nodes.push_back(node);
  }
  st.kept = static_cast<int64_t>(out.nodes.size());
  return out;
}

}  // namespace riskplan
