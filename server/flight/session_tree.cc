#include "server/flight/session_tree.h"

#include <string_view>
#include <utility>
#include <vector>

namespace riskplan::server {
namespace {

// RISK_RRT_STAR's max_nodes for `options`: the request's, else the default.
double MaxNodes(const PlanOptions& options) {
  if (const auto it = options.params.find("max_nodes"); it != options.params.end()) {
    return it->second;
  }
  for (const PlannerParamInfo& p : PlannerParams(PlannerAlgorithm::kRiskRrtStar)) {
    if (p.name == "max_nodes") return p.default_value;
  }
  return 0.0;
}

// True when `b` gives every configuration the risk `a` gives: the same
// model parameters (the wind among them) over maps that differ at most in
// their no-fly cells (RiskMap::WithNoFly). Only admissibility may differ.
bool SameRisks(const RiskModel& a, const RiskModel& b) {
  if (!a.map().SharesLayersWith(b.map())) return false;
  for (std::string_view name : ModelParamNames()) {
    const absl::StatusOr<double> x = GetModelParam(a.params(), name);
    const absl::StatusOr<double> y = GetModelParam(b.params(), name);
    if (!x.ok() || !y.ok() || !(*x == *y)) return false;
  }
  return true;
}

}  // namespace

void SessionTree::Reset() {
  if (tree_ != nullptr) ++stats_.resets;
  tree_.reset();
  tree_model_.reset();
  stats_.tree_nodes = 0;
}

absl::StatusOr<PlanResult> SessionTree::Plan(const std::shared_ptr<const RiskModel>& model,
                                             PlannerAlgorithm algorithm, const Pose& from,
                                             const Pose& goal, const PlanOptions& options,
                                             RiskEvaluator* evaluator,
                                             const CancellationToken& cancel,
                                             const ImprovementCallback& on_improvement) {
  ++stats_.plans;
  if (algorithm != PlannerAlgorithm::kRiskRrtStar || options.limits.Active()) {
    absl::StatusOr<std::unique_ptr<Planner>> planner = MakePlanner(algorithm, evaluator);
    if (!planner.ok()) return planner.status();
    return (*planner)->Plan(PlanningProblem{model, from, goal}, options, cancel, on_improvement);
  }
  // The kept tree, if it is this goal's and these parameters', fits the
  // bound, and survives the pruning for this model.
  if (tree_ != nullptr &&
      (tree_->params != options.params || tree_->goal.x != goal.x || tree_->goal.y != goal.y ||
       tree_->goal.z != goal.z || tree_->goal.theta != goal.theta ||
       static_cast<double>(tree_->nodes.size()) > 0.5 * MaxNodes(options))) {
    Reset();
  }
  // A new wind, new parameters or another map: every risk changes.
  if (tree_ != nullptr && tree_model_ != model && !SameRisks(*tree_model_, *model)) Reset();
  if (tree_ != nullptr && tree_model_ != model) {
    // Only where the new model is stricter (cells closed, glide altitudes
    // raised) can an edge have become inadmissible; nowhere (a zone removed):
    // the tree holds as it is.
    const std::optional<PruneRegion> region = StricterRegion(*tree_model_, *model);
    stats_.last_prune = GoalTreePruneStats{};
    stats_.last_prune.kept = static_cast<int64_t>(tree_->nodes.size());
    if (region.has_value()) {
      absl::StatusOr<GoalTree> pruned =
          PruneGoalTree(*tree_, *model, StopCondition(&cancel), &stats_.last_prune, region);
      if (!pruned.ok()) return pruned.status();
      tree_ =
          pruned->nodes.empty() ? nullptr : std::make_shared<const GoalTree>(*std::move(pruned));
    }
    if (tree_ == nullptr) {
      ++stats_.resets;  // the goal closed: grow from it again when it opens
      tree_model_.reset();
      stats_.tree_nodes = 0;
    } else {
      tree_model_ = model;
      stats_.tree_nodes = static_cast<int64_t>(tree_->nodes.size());
    }
  }
  SharedTreeProblem problem;
  problem.model = model;
  problem.goal = goal;
  SharedTreeMission mission;
  mission.start = from;
  mission.budget = options.budget;
  problem.missions.push_back(mission);
  SharedTreeOptions shared;
  shared.seed = tree_ != nullptr ? tree_->seed : options.seed;
  shared.params = options.params;
  shared.max_edge_samples = options.max_edge_samples;
  shared.initial_tree = tree_;
  if (tree_ != nullptr) ++stats_.from_tree;
  SharedGoalTreePlanner planner(evaluator);
  GoalTree grown;
  absl::StatusOr<std::vector<absl::StatusOr<PlanResult>>> results = planner.Plan(
      problem, shared, cancel,
      [&](size_t, const PlanImprovement& improvement) {
        if (on_improvement) on_improvement(improvement);
      },
      nullptr, &grown);
  if (!results.ok()) return results.status();
  if (!grown.nodes.empty()) {
    tree_ = std::make_shared<const GoalTree>(std::move(grown));
    tree_model_ = model;
    stats_.tree_nodes = static_cast<int64_t>(tree_->nodes.size());
  }
  if (results->size() != 1) {
    return absl::InternalError("the session's tree planner returned no result for its mission");
  }
  return std::move((*results)[0]);
}

}  // namespace riskplan::server
