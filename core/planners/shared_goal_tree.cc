#include "core/planners/shared_goal_tree.h"

#include <optional>
#include <utility>

#include "absl/strings/str_format.h"
#include "core/planners/planner_support.h"
#include "core/planners/risk_rrt_star_run.h"

namespace riskplan {
namespace {

absl::Status MissionError(size_t index, const absl::Status& status) {
  return absl::Status(status.code(), absl::StrFormat("missions[%d]: %s", index, status.message()));
}

// A mission's own checks, in RISK_RRT_STAR's order: its start, its budget,
// the samples of the edges it may fly.
absl::Status CheckMission(const SharedTreeProblem& problem, const SharedTreeOptions& options,
                          const SharedTreeMission& mission) {
  const PlanningProblem single{problem.model, mission.start, problem.goal};
  if (absl::Status s = CheckEndpoints(single); !s.ok()) return s;
  if (absl::Status s = CheckBudget(mission.budget); !s.ok()) return s;
  return CheckEdgeSampleBound(PlannerAlgorithm::kRiskRrtStar, problem.model->map(),
                              problem.model->params(), mission.start, problem.goal, options.params,
                              options.max_edge_samples);
}

// The checks SharedTreeOptions::initial_tree states: a tree grown for
// another goal, parameters or seed is never used.
absl::Status CheckInitialTree(const GoalTree& tree, const Pose& goal,
                              const SharedTreeOptions& options, int64_t max_nodes) {
  const auto same = [](const Pose& a, const Pose& b) {
    return a.x == b.x && a.y == b.y && a.z == b.z && a.theta == b.theta;
  };
  if (!same(tree.goal, goal)) return absl::InvalidArgumentError("initial_tree: another goal");
  if (tree.params != options.params) {
    return absl::InvalidArgumentError("initial_tree: other planner parameters");
  }
  if (tree.seed != options.seed) return absl::InvalidArgumentError("initial_tree: another seed");
  if (tree.nodes.empty() || !same(tree.nodes[0].pose, goal) || tree.nodes[0].parent != -1) {
    return absl::InvalidArgumentError("initial_tree: node 0 is not the goal");
  }
  if (static_cast<int64_t>(tree.nodes.size()) > max_nodes) {
    return absl::InvalidArgumentError(
        absl::StrFormat("initial_tree: %d nodes, more than max_nodes", tree.nodes.size()));
  }
  for (size_t i = 1; i < tree.nodes.size(); ++i) {
    const int32_t parent = tree.nodes[i].parent;
    if (parent < 0 || static_cast<size_t>(parent) >= tree.nodes.size() ||
        static_cast<size_t>(parent) == i) {
      return absl::InvalidArgumentError(absl::StrFormat("initial_tree: node %d's parent", i));
    }
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<std::vector<absl::StatusOr<PlanResult>>> SharedGoalTreePlanner::Plan(
    const SharedTreeProblem& problem, const SharedTreeOptions& options,
    const CancellationToken& cancel, const MissionImprovementCallback& on_improvement,
    const MissionResultCallback& on_result, GoalTree* grown_tree) {
  if (grown_tree != nullptr) grown_tree->nodes.clear();
  if (problem.model == nullptr) return absl::InvalidArgumentError("planning problem has no model");
  if (problem.missions.empty()) return absl::InvalidArgumentError("missions: none given");
  if (problem.missions.size() > kMaxSharedTreeMissions) {
    return absl::InvalidArgumentError(
        absl::StrFormat("missions: %d given; at most %d share one tree", problem.missions.size(),
                        kMaxSharedTreeMissions));
  }
  if (absl::Status s = CheckEndpoint(*problem.model, problem.goal, "goal"); !s.ok()) return s;
  auto params = rrt_star::Params::Parse(options.params);
  if (!params.ok()) return params.status();
  const GoalTree* initial = options.initial_tree.get();
  if (initial != nullptr) {
    if (absl::Status s = CheckInitialTree(*initial, problem.goal, options, params->max_nodes);
        !s.ok()) {
      return s;
    }
  }
  const int64_t generation = initial != nullptr ? initial->generation : 0;

  std::vector<std::optional<absl::StatusOr<PlanResult>>> results(problem.missions.size());
  const auto deliver = [&](size_t index, absl::StatusOr<PlanResult> result) {
    if (on_result) on_result(index, result);
    results[index] = std::move(result);
  };
  // Invalid missions get their own error now; the others share the tree.
  std::vector<size_t> planned;  // run index -> mission index
  std::vector<rrt_star::RunMission> run_missions;
  for (size_t i = 0; i < problem.missions.size(); ++i) {
    const SharedTreeMission& mission = problem.missions[i];
    if (absl::Status s = CheckMission(problem, options, mission); !s.ok()) {
      deliver(i, MissionError(i, s));
      continue;
    }
    planned.push_back(i);
    run_missions.push_back({mission.start, mission.budget});
  }
  if (!run_missions.empty()) {
    std::unique_ptr<RiskEvaluator> own;
    RiskEvaluator* evaluator = evaluator_;
    if (evaluator == nullptr) {
      own = rrt_star::OwnEvaluator(*params);
      evaluator = own.get();
    }
    rrt_star::RunCallbacks callbacks;
    if (on_improvement) {
      callbacks.on_improvement = [&](size_t run_index, const PlanImprovement& improvement) {
        on_improvement(planned[run_index], improvement);
      };
    }
    callbacks.on_result = [&](size_t run_index, absl::StatusOr<PlanResult> result) {
      deliver(planned[run_index], std::move(result));
    };
    rrt_star::Run run(*problem.model, problem.goal, std::move(run_missions),
                      GoalTree::PlanSeed(options.seed, generation), options.record_tree, *params,
                      evaluator, cancel, std::move(callbacks), initial);
    run.Execute();
    // A guide route may take the tree past max_nodes (it is checked between
    // steps); such a tree is not exported, so that every exported tree is one
    // a plan with these parameters accepts.
    if (grown_tree != nullptr && run.ExportTree(grown_tree) &&
        static_cast<int64_t>(grown_tree->nodes.size()) > params->max_nodes) {
      grown_tree->nodes.clear();
    }
    if (grown_tree != nullptr && !grown_tree->nodes.empty()) {
      grown_tree->goal = problem.goal;
      grown_tree->params = options.params;
      grown_tree->seed = options.seed;
      grown_tree->generation = generation + 1;
    }
  }
  std::vector<absl::StatusOr<PlanResult>> out;
  out.reserve(results.size());
  for (std::optional<absl::StatusOr<PlanResult>>& r : results) {
    // Execute gives every planned mission exactly one result.
    out.push_back(r.has_value()
                      ? std::move(*r)
                      : absl::InternalError("the shared tree gave this mission no result"));
  }
  return out;
}

}  // namespace riskplan
