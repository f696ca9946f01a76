#include "core/planners/goal_tree_repair.h"

#include <algorithm>
#include <memory>
#include <optional>
#include <vector>

#include "absl/strings/str_format.h"
#include "core/flight/piece_risk.h"
#include "core/flight/trajectory_piece.h"

namespace riskplan {
namespace {

enum class NodeState : uint8_t { kUnknown, kVisiting, kKept, kDropped };

}  // namespace

std::optional<PruneRegion> StricterRegion(const RiskModel& before, const RiskModel& after) {
  const RiskMap& a = before.map();
  const RiskMap& b = after.map();
  const std::vector<uint8_t>& nofly_a = a.nofly_layer();
  const std::vector<uint8_t>& nofly_b = b.nofly_layer();
  const std::shared_ptr<const std::vector<double>> glide_a = before.glide_layer();
  const std::shared_ptr<const std::vector<double>> glide_b = after.glide_layer();
  const bool same_glide =
      glide_a == glide_b || glide_a == nullptr || glide_b == nullptr || b.landing_sites().empty();
  int i_min = b.nx(), j_min = b.ny(), i_max = -1, j_max = -1;
  for (int j = 0; j < b.ny(); ++j) {
    for (int i = 0; i < b.nx(); ++i) {
      const int64_t k = b.Index(i, j);
      const bool stricter =
          (nofly_b[k] != 0 && nofly_a[k] == 0) || (!same_glide && (*glide_b)[k] > (*glide_a)[k]);
      if (!stricter) continue;
      i_min = std::min(i_min, i);
      j_min = std::min(j_min, j);
      i_max = std::max(i_max, i);
      j_max = std::max(j_max, j);
    }
  }
  if (i_max < 0) return std::nullopt;
  return PruneRegion{b.x0() + i_min * b.res(), b.y0() + j_min * b.res(),
                     b.x0() + (i_max + 1) * b.res(), b.y0() + (j_max + 1) * b.res()};
}

absl::StatusOr<GoalTree> PruneGoalTree(const GoalTree& tree, const RiskModel& model,
                                       const StopCondition& stop, GoalTreePruneStats* stats,
                                       const std::optional<PruneRegion>& region) {
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
  // Whether the disc of radius r around p meets the region (a cell's square
  // counts as reached from anywhere within it: the margin of one cell).
  const double margin = model.map().res();
  const auto reaches = [&](const Pose& p, double r) {
    if (!region.has_value()) return true;
    return p.x + r + margin >= region->x_min && p.x - r - margin <= region->x_max &&
           p.y + r + margin >= region->y_min && p.y - r - margin <= region->y_max;
  };
  const auto edge_holds = [&](int64_t k) {
    const GoalTreeNode& node = tree.nodes[k];
    if (node.parent < 0) return !reaches(node.pose, 0.0) || admissible(node.pose);
    const Pose& to = tree.nodes[node.parent].pose;
    const TrajectoryPiece piece =
        TrajectoryPiece::Manoeuvre(node.pose, to, mp.GroundTurnRadius(), mp.GroundClimbAngle());
    // Every pose of the edge lies within its length of both ends.
    const double length = piece.Length();
    if (!reaches(node.pose, length) || !reaches(to, length)) {
      ++st.skipped_edges;
      return true;
    }
    if (!admissible(node.pose)) return false;
    const PieceRisk rule(piece, mp.sample_step_m, mp);
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
