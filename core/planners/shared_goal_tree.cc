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

}  // namespace

absl::StatusOr<std::vector<absl::StatusOr<PlanResult>>> SharedGoalTreePlanner::Plan(
    const SharedTreeProblem& problem, const SharedTreeOptions& options,
    const CancellationToken& cancel, const MissionImprovementCallback& on_improvement,
    const MissionResultCallback& on_result) {
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
    rrt_star::Run run(*problem.model, problem.goal, std::move(run_missions), options.seed,
                      options.record_tree, *params, evaluator, cancel, std::move(callbacks));
    run.Execute();
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
