// SharedGoalTreePlanner: several missions that share a goal pose, a map, the
// model and planner parameters and a seed, answered from one RISK_RRT_STAR
// tree (core/planners/risk_rrt_star.h).
//
// RISK_RRT_STAR grows its tree from the goal, and its start is a node that is
// never a parent, so one tree can serve many starts: every mission's start is
// such a node, the tree keeps growing while any mission runs, and each
// mission's trajectory is the tree's path from its own start. What a tree
// learns about the area around the goal (a depot, a hospital pad) is paid for
// once. RISK_RRT_STAR itself is the case of one mission, bit for bit.
//
// How the shared work is divided (docs/planners.md, "Shared goal trees"):
// - branch and bound refuses only what no running mission can use: its bound
//   is the largest current risk among running missions, +inf while any of
//   them has no solution;
// - the start samples, the samples around a best trajectory and the
//   refinement edits go round-robin over the running missions; a tree
//   iteration earns refine_edits edits, times S / 4 when S > 4 running
//   missions have a solution (an edit serves one mission, the tree all);
//   each start gets its own guide route (one coarse risk grid, built once);
// - each mission has its own budget; when it ends, that mission's final
//   result is reported while the tree grows on for the others.
// Every reported risk is still the sum of exact piece risks: bit for bit what
// EvaluateTrajectory gives for the reported waypoints.
//
// Deterministic: the same problem, options and seed, with iteration budgets,
// give the same trajectories, improvements and order of results bit for bit.
// (A mission's iterations are the shared tree's, so its result depends on
// the whole fleet, not on its own start alone.)
#ifndef RISKPLAN_CORE_PLANNERS_SHARED_GOAL_TREE_H_
#define RISKPLAN_CORE_PLANNERS_SHARED_GOAL_TREE_H_

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/cancellation.h"
#include "core/base/geometry.h"
#include "core/planners/planner.h"
#include "core/risk/risk_evaluator.h"
#include "core/risk/risk_model.h"

namespace riskplan {

// Most missions one tree serves (SharedGoalTreePlanner::Plan refuses more).
// Each is a start node, a best trajectory and a result: a few kB apiece; what
// bounds the work is every mission's budget and max_nodes.
inline constexpr size_t kMaxSharedTreeMissions = 256;

// A goal tree as SharedGoalTreePlanner grew it, without its starts: derived
// data that a later plan with the same goal, model (map + model parameters),
// planner parameters and seed may begin from instead of the goal alone.
// Every node keeps its parent, R(node) and the exact piece risk of the edge
// to its parent, so a trajectory through it still reports the exact sum of
// its piece risks. The starts were leaves (never parents): they are dropped
// and the other nodes renumbered in their order, node 0 the goal.
//
// The model is not recorded: a tree is only valid for the model it was grown
// with, and the caller must key it by that model (server/models/goal_tree_cache.h
// keys by the map's name and identity and every model parameter).
struct GoalTreeNode {
  Pose pose;
  int32_t parent = -1;     // -1 for the goal only
  double cost = 0.0;       // R(node): risk from here to the goal along the tree
  double edge_risk = 0.0;  // piece risk of the edge to the parent (0 for the goal)
};

struct GoalTree {
  Pose goal;                             // == nodes[0].pose
  std::map<std::string, double> params;  // RISK_RRT_STAR's parameters, as given
  uint64_t seed = 1;                     // the seed of the plans that grew it
  // How many plans grew it. A plan that begins from a tree of generation g
  // draws its random numbers from PlanSeed(seed, g), and exports generation
  // g + 1: the same tree and seed give the same plan, and two generations do
  // not replay one random stream over an already grown tree.
  int64_t generation = 0;
  std::vector<GoalTreeNode> nodes;

  // seed for generation 0 (a plan from the goal alone: bit for bit the plan
  // without a tree), else seed + g times the 64-bit golden ratio, wrapping.
  static uint64_t PlanSeed(uint64_t seed, int64_t generation) {
    return seed + static_cast<uint64_t>(generation) * 0x9E3779B97F4A7C15ULL;
  }
};

struct SharedTreeMission {
  Pose start;
  // This mission's own budget: iterations of the shared tree and/or wall
  // time since the plan began (CheckBudget's rules).
  PlannerBudget budget;
};

struct SharedTreeProblem {
  std::shared_ptr<const RiskModel> model;   // map + parameters, shared
  Pose goal;                                // shared
  std::vector<SharedTreeMission> missions;  // 1 ... kMaxSharedTreeMissions
};

// What the missions share besides the problem: RISK_RRT_STAR's parameters
// and the seed.
struct SharedTreeOptions {
  uint64_t seed = 1;
  // RISK_RRT_STAR's parameters by name (PlannerParams(kRiskRrtStar)); max_nodes
  // bounds the one shared tree.
  std::map<std::string, double> params;
  // Keep the final tree (edges as polylines) in the result of the mission
  // that ends last (once, not in every result).
  bool record_tree = false;
  // The edge-sample bound of PlanOptions::max_edge_samples, checked for
  // every start (CheckEdgeSamples).
  int64_t max_edge_samples = kDefaultMaxEdgeSamples;
  // Begin from this tree instead of the goal alone (null: from the goal).
  // The planner copies it and never changes it, so it may be shared with
  // other plans. It must have been grown for the same model; its goal,
  // params and seed must equal the problem's and these options' bit for bit
  // and it must hold at most max_nodes nodes (else Plan fails with
  // InvalidArgument naming "initial_tree"). Each start is first connected to
  // the tree as it stands; then the plan runs as from the goal (guide
  // routes, bound, budgets), with the seed GoalTree::PlanSeed gives.
  std::shared_ptr<const GoalTree> initial_tree;
};

// An improvement of mission `mission` (its index in the problem), in order of
// strictly decreasing risk for that mission.
using MissionImprovementCallback =
    std::function<void(size_t mission, const PlanImprovement& improvement)>;
// The one final result of mission `mission`: its PlanResult, or its own
// error (InvalidArgument for a bad start, budget or edge-sample bound; an
// evaluator's error). Called once per mission, in the order they end.
using MissionResultCallback =
    std::function<void(size_t mission, const absl::StatusOr<PlanResult>& result)>;

class SharedGoalTreePlanner {
 public:
  // `evaluator` computes the risk batches of every mission (when null, the
  // planner's own, as RISK_RRT_STAR chooses it from risk_cache_log2); it must
  // outlive the planner. If it stops on a condition of its own, that must be
  // the whole call's (its cancellation, the latest mission deadline): it
  // serves the missions that are still running when the first ones end.
  explicit SharedGoalTreePlanner(RiskEvaluator* evaluator = nullptr) : evaluator_(evaluator) {}

  // Plans every mission on one tree and returns their results by index.
  //
  // An error (InvalidArgument) only for what all missions share, before any
  // callback: no model, an inadmissible goal (the message names "goal" and
  // the violation), no missions or more than kMaxSharedTreeMissions, an
  // unknown or out-of-range parameter. A mission whose start is not
  // admissible (CheckEndpoints), whose budget is invalid (CheckBudget) or
  // whose edges could exceed max_edge_samples gets that error as its result,
  // its message prefixed with "missions[i]: ", reported before planning
  // begins; the other missions are planned.
  //
  // Results come through `on_result` as missions end: all invalid missions
  // first (in index order), then each planned mission when its budget ends
  // (reason BUDGET_EXHAUSTED, or NO_SOLUTION without a trajectory) or its
  // risk reaches 0 (CONVERGED); missions that end at the same iteration come
  // in index order. The token cancels every running mission (CANCELLED), and
  // reaching max_nodes ends all of them (BUDGET_EXHAUSTED). A PlanResult's
  // iterations, tree_size and configurations_evaluated are the shared tree's
  // when the mission ended; its elapsed_s counts from the start of Plan().
  // Both callbacks may be null; they run on the caller's thread, must not
  // block for long, and must not call Plan() again on this planner.
  //
  // With `grown_tree` not null, the tree as it stands at the end (without
  // its starts) is written there, its generation one more than
  // initial_tree's (1 without); it is left with no nodes when no mission was
  // planned, an evaluator's error ended the plan, or the tree has more than
  // max_nodes nodes (a guide route can pass the bound), so that every tree
  // exported is one a plan with the same options accepts.
  absl::StatusOr<std::vector<absl::StatusOr<PlanResult>>> Plan(
      const SharedTreeProblem& problem, const SharedTreeOptions& options,
      const CancellationToken& cancel, const MissionImprovementCallback& on_improvement,
      const MissionResultCallback& on_result, GoalTree* grown_tree = nullptr);

 private:
  RiskEvaluator* evaluator_;
};

}  // namespace riskplan

#endif  // RISKPLAN_CORE_PLANNERS_SHARED_GOAL_TREE_H_
