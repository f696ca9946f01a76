#include "server/fleet/fleet_group.h"

#include <algorithm>
#include <chrono>
#include <exception>
#include <optional>
#include <string>
#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_format.h"
#include "core/planners/shared_goal_tree.h"
#include "server/api/status_util.h"

namespace riskplan::server {
namespace {

PlanResult Unplanned() {
  PlanResult result;
  result.reason = StopReason::kCancelled;
  return result;
}

}  // namespace

void FleetGroup::Offer(size_t mission, const absl::StatusOr<PlanResult>& result) {
  for (size_t k = 0; k < group_.missions.size(); ++k) {
    if (group_.missions[k] == mission) reported_[k] = true;
  }
  call_->OfferResult(mission, result);
}

std::unique_ptr<RiskEvaluator> FleetGroup::NewEvaluator(const PlanOptions& options,
                                                        double max_time_s) const {
  // As PlanCall's: the evaluator stops waiting for boards once the call is
  // cancelled or (for one mission) its time budget is over.
  std::optional<std::chrono::steady_clock::time_point> deadline;
  if (max_time_s > 0.0) {
    deadline = std::chrono::steady_clock::now() +
               std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                   std::chrono::duration<double>(max_time_s));
  }
  return NewPlanEvaluator(engine_, options,
                          StopCondition(&call_->cancel_token(), nullptr, deadline));
}

void FleetGroup::Run() {
  reported_.assign(group_.missions.size(), false);
  try {
    if (call_->cancel_token().IsCancelled()) {
      for (size_t m : group_.missions) Offer(m, Unplanned());
      return;
    }
    if (group_.shared) {
      PlanShared();
    } else {
      PlanAlone(group_.missions.front());
    }
  } catch (const std::exception& e) {
    for (size_t k = 0; k < group_.missions.size(); ++k) {
      if (reported_[k]) continue;
      Offer(group_.missions[k],
            MissionError(group_.missions[k], StatusFromException(e, "PlanFleet")));
    }
  }
}

void FleetGroup::EndUnplanned() {
  reported_.assign(group_.missions.size(), false);
  // The call's planning groups go on until the drain stops them.
  call_->MarkShutdown();
  for (size_t m : group_.missions) Offer(m, Unplanned());
}

void FleetGroup::PlanAlone(size_t mission) {
  const PlanSpec& spec = *spec_->missions[mission].plan;
  absl::StatusOr<std::shared_ptr<const RiskModel>> model = models_->Get(*spec.map, spec.params);
  if (!model.ok()) {
    // A build stopped by the drain ends as the drain does.
    Offer(mission, absl::IsCancelled(model.status()) && call_->cancel_token().IsCancelled()
                       ? absl::StatusOr<PlanResult>(Unplanned())
                       : MissionError(mission, InField("model_params", model.status())));
    return;
  }
  std::unique_ptr<RiskEvaluator> evaluator =
      NewEvaluator(spec.options, spec.options.budget.max_time_s);
  absl::StatusOr<std::unique_ptr<Planner>> planner = MakePlanner(spec.algorithm, evaluator.get());
  if (!planner.ok()) {
    Offer(mission, MissionError(mission, planner.status()));
    return;
  }
  absl::StatusOr<PlanResult> result = (*planner)->Plan(
      PlanningProblem{*model, spec.start, spec.goal}, spec.options, call_->cancel_token(),
      [&](const PlanImprovement& improvement) { call_->OfferImprovement(mission, improvement); });
  if (!result.ok()) result = MissionError(mission, result.status());
  Offer(mission, result);
}

void FleetGroup::PlanShared() {
  // Every mission of the group has the same map, goal, parameters and seed
  // (GroupMissions): the first one's stand for all.
  const PlanSpec& first = *spec_->missions[group_.missions.front()].plan;
  absl::StatusOr<std::shared_ptr<const RiskModel>> model = models_->Get(*first.map, first.params);
  if (!model.ok()) {
    for (size_t m : group_.missions) {
      Offer(m, absl::IsCancelled(model.status()) && call_->cancel_token().IsCancelled()
                   ? absl::StatusOr<PlanResult>(Unplanned())
                   : MissionError(m, InField("model_params", model.status())));
    }
    return;
  }
  SharedTreeProblem problem{.model = *model, .goal = first.goal, .missions = {}};
  SharedTreeOptions options{.seed = first.options.seed,
                            .params = first.options.params,
                            .record_tree = false,
                            .max_edge_samples = first.options.max_edge_samples,
                            .initial_tree = nullptr};
  for (size_t m : group_.missions) {
    const PlanSpec& spec = *spec_->missions[m].plan;
    problem.missions.push_back({.start = spec.start, .budget = spec.options.budget});
    options.record_tree = options.record_tree || spec.options.record_tree;
  }
  // With the cache, the group begins from the tree an earlier group grew
  // for the same key (the planner copies it: a tree is shared read-only).
  GoalTreeKey key;
  std::optional<GoalTree> grown;
  if (goal_trees_ != nullptr) {
    key = GoalTreeKey{.map_name = first.map->name(),
                      .map_identity = reinterpret_cast<uintptr_t>(first.map.get()),
                      .goal = first.goal,
                      .model_params = first.params,
                      .planner_params = first.options.params,
                      .seed = first.options.seed};
    options.initial_tree = goal_trees_->Find(key);
    grown.emplace();
  }
  // The evaluator serves the missions that still run when the first ones
  // end: it stops on the call's cancel only (SharedGoalTreePlanner's rule).
  std::unique_ptr<RiskEvaluator> evaluator = NewEvaluator(first.options, 0.0);
  SharedGoalTreePlanner planner(evaluator.get());
  absl::StatusOr<std::vector<absl::StatusOr<PlanResult>>> results = planner.Plan(
      problem, options, call_->cancel_token(),
      [&](size_t k, const PlanImprovement& improvement) {
        call_->OfferImprovement(group_.missions[k], improvement);
      },
      [&](size_t k, const absl::StatusOr<PlanResult>& result) {
        const size_t m = group_.missions[k];
        if (result.ok()) {
          Offer(m, result);
          return;
        }
        // The planner names the mission by its index in the group; the
        // client knows it by its index in the request.
        std::string message(result.status().message());
        const std::string prefix = absl::StrFormat("missions[%d]: ", k);
        if (absl::StartsWith(message, prefix)) message.erase(0, prefix.size());
        Offer(m, MissionError(m, absl::Status(result.status().code(), message)));
      },
      grown.has_value() ? &*grown : nullptr);
  // The tree goes back when it grew (a plan cut short by a cancel or a
  // deadline still leaves a valid tree: every node's edge risk is exact).
  if (results.ok() && grown.has_value() && !grown->nodes.empty() &&
      (options.initial_tree == nullptr ||
       grown->nodes.size() > options.initial_tree->nodes.size())) {
    goal_trees_->Put(key, std::make_shared<const GoalTree>(*std::move(grown)));
  }
  if (!results.ok()) {
    // What the missions share failed (the goal, a planner parameter): each
    // mission gets the error.
    for (size_t m : group_.missions) Offer(m, MissionError(m, results.status()));
  }
}

}  // namespace riskplan::server
