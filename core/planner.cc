#include "core/planner.h"

#include <cmath>

#include "absl/strings/str_format.h"
#include "core/risk_rrt_star.h"
#include "core/trajectory.h"

namespace riskplan {

std::string_view PlannerAlgorithmName(PlannerAlgorithm algorithm) {
  switch (algorithm) {
    case PlannerAlgorithm::kRiskRrtStar:
      return "RISK_RRT_STAR";
  }
  return "UNKNOWN";
}

std::string_view StopReasonName(StopReason reason) {
  switch (reason) {
    case StopReason::kBudgetExhausted:
      return "BUDGET_EXHAUSTED";
    case StopReason::kConverged:
      return "CONVERGED";
    case StopReason::kCancelled:
      return "CANCELLED";
    case StopReason::kNoSolution:
      return "NO_SOLUTION";
  }
  return "UNKNOWN";
}

absl::StatusOr<std::unique_ptr<Planner>> MakePlanner(PlannerAlgorithm algorithm,
                                                     RiskEvaluator* evaluator) {
  switch (algorithm) {
    case PlannerAlgorithm::kRiskRrtStar:
      return std::unique_ptr<Planner>(new RiskRrtStar(evaluator));
  }
  return absl::InvalidArgumentError(
      absl::StrFormat("unknown planner algorithm %d", static_cast<int>(algorithm)));
}

const std::vector<PlannerParamInfo>& PlannerParams(PlannerAlgorithm algorithm) {
  switch (algorithm) {
    case PlannerAlgorithm::kRiskRrtStar:
      return RiskRrtStar::ParamInfo();
  }
  static const auto* empty = new std::vector<PlannerParamInfo>;
  return *empty;
}

namespace {

absl::Status CheckEndpoint(const RiskModel& model, const Pose& pose, const char* which) {
  for (auto [field, value] :
       {std::pair{"x", pose.x}, {"y", pose.y}, {"z", pose.z}, {"theta", pose.theta}}) {
    if (!std::isfinite(value)) {
      return absl::InvalidArgumentError(
          absl::StrFormat("%s.%s is %g; it must be finite", which, field, value));
    }
  }
  double limit = 0.0;
  const ViolationKind kind = model.CheckConfiguration(pose, &limit);
  if (kind == ViolationKind::kNone) return absl::OkStatus();
  Violation v{kind, pose, 0.0, 0, limit};
  std::string detail = v.ToString();
  // Drop the arc-length part, which means nothing for a single pose.
  if (size_t cut = detail.find(", arc length"); cut != std::string::npos) {
    size_t colon = detail.find(':', cut);
    detail = detail.substr(0, cut) + (colon == std::string::npos ? "" : detail.substr(colon));
  }
  return absl::InvalidArgumentError(
      absl::StrFormat("%s pose (%.1f, %.1f, %.1f) on map '%s' is not admissible: %s", which, pose.x,
                      pose.y, pose.z, model.map().name(), detail));
}

}  // namespace

absl::Status CheckEndpoints(const PlanningProblem& problem) {
  if (problem.model == nullptr) return absl::InvalidArgumentError("planning problem has no model");
  if (absl::Status s = CheckEndpoint(*problem.model, problem.start, "start"); !s.ok()) return s;
  return CheckEndpoint(*problem.model, problem.goal, "goal");
}

}  // namespace riskplan
