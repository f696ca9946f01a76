#include "core/planners/planner.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_format.h"
#include "core/flight/piece_risk.h"
#include "core/flight/trajectory.h"
#include "core/planners/genetic_planner.h"
#include "core/planners/harmonic_planner.h"
#include "core/planners/limit_filter.h"
#include "core/planners/risk_rrt_star.h"
#include "core/planners/rrt_planner.h"

namespace riskplan {

std::string_view PlannerAlgorithmName(PlannerAlgorithm algorithm) {
  switch (algorithm) {
    case PlannerAlgorithm::kRiskRrtStar:
      return "RISK_RRT_STAR";
    case PlannerAlgorithm::kRrt:
      return "RRT";
    case PlannerAlgorithm::kGenetic:
      return "GENETIC";
    case PlannerAlgorithm::kHarmonic:
      return "HARMONIC";
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

namespace {

// The entry of `algorithm`; null for a value outside the enum.
const AlgorithmEntry* EntryOf(PlannerAlgorithm algorithm) {
  switch (algorithm) {
    case PlannerAlgorithm::kRiskRrtStar:
      return &kRiskRrtStarEntry;
    case PlannerAlgorithm::kRrt:
      return &kRrtEntry;
    case PlannerAlgorithm::kGenetic:
      return &kGeneticEntry;
    case PlannerAlgorithm::kHarmonic:
      return &kHarmonicEntry;
  }
  return nullptr;
}

// The planner of every algorithm: the caller's evaluator, handed to the
// algorithm's Plan() with each call.
class AlgorithmPlanner final : public Planner {
 public:
  AlgorithmPlanner(PlannerAlgorithm algorithm, const AlgorithmEntry& entry,
                   RiskEvaluator* evaluator)
      : algorithm_(algorithm), entry_(entry), evaluator_(evaluator) {}

  absl::StatusOr<PlanResult> Plan(const PlanningProblem& problem, const PlanOptions& options,
                                  const CancellationToken& cancel,
                                  const ImprovementCallback& on_improvement) override {
    return PlanWithLimits(
        algorithm_,
        [&](const PlanOptions& pass, const ImprovementCallback& report) {
          return entry_.plan(evaluator_, problem, pass, cancel, report);
        },
        problem, options, evaluator_, on_improvement);
  }

 private:
  const PlannerAlgorithm algorithm_;
  const AlgorithmEntry& entry_;
  RiskEvaluator* evaluator_;
};

}  // namespace

absl::StatusOr<std::unique_ptr<Planner>> MakePlanner(PlannerAlgorithm algorithm,
                                                     RiskEvaluator* evaluator) {
  const AlgorithmEntry* entry = EntryOf(algorithm);
  if (entry == nullptr) {
    return absl::InvalidArgumentError(
        absl::StrFormat("unknown planner algorithm %d", static_cast<int>(algorithm)));
  }
  return std::unique_ptr<Planner>(new AlgorithmPlanner(algorithm, *entry, evaluator));
}

const std::vector<PlannerParamInfo>& PlannerParams(PlannerAlgorithm algorithm) {
  const AlgorithmEntry* entry = EntryOf(algorithm);
  if (entry != nullptr) return entry->param_info();
  static const auto* empty = new std::vector<PlannerParamInfo>;
  return *empty;
}

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

absl::Status CheckEndpoints(const PlanningProblem& problem) {
  if (problem.model == nullptr) return absl::InvalidArgumentError("planning problem has no model");
  if (absl::Status s = CheckEndpoint(*problem.model, problem.start, "start"); !s.ok()) return s;
  return CheckEndpoint(*problem.model, problem.goal, "goal");
}

absl::Status CheckRequestObstacles(PlannerAlgorithm algorithm, const PlanOptions& options) {
  const std::string_view name = PlannerAlgorithmName(algorithm);
  if (!options.obstacle_points.empty() && algorithm == PlannerAlgorithm::kRiskRrtStar) {
    return absl::InvalidArgumentError(
        absl::StrFormat("obstacle_points: %s does not take request obstacles; RRT, GENETIC and "
                        "HARMONIC do",
                        name));
  }
  if (!options.dynamic_obstacles.empty() && algorithm != PlannerAlgorithm::kHarmonic) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "dynamic_obstacles: %s does not take obstacles that appear while it runs; HARMONIC does",
        name));
  }
  if (options.obstacle_points.size() > kMaxObstaclePoints) {
    return absl::InvalidArgumentError(
        absl::StrFormat("obstacle_points: %d given; at most %d are accepted",
                        options.obstacle_points.size(), kMaxObstaclePoints));
  }
  if (options.dynamic_obstacles.size() > kMaxDynamicObstacles) {
    return absl::InvalidArgumentError(
        absl::StrFormat("dynamic_obstacles: %d given; at most %d are accepted",
                        options.dynamic_obstacles.size(), kMaxDynamicObstacles));
  }
  for (size_t k = 0; k < options.obstacle_points.size(); ++k) {
    const Point2& p = options.obstacle_points[k];
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "obstacle_points[%d] is (%g, %g); coordinates must be finite", k, p.x, p.y));
    }
  }
  for (size_t k = 0; k < options.dynamic_obstacles.size(); ++k) {
    const DynamicObstacle& d = options.dynamic_obstacles[k];
    if (!std::isfinite(d.x0_m) || !std::isfinite(d.y0_m) || !std::isfinite(d.x1_m) ||
        !std::isfinite(d.y1_m) || !(d.x0_m < d.x1_m) || !(d.y0_m < d.y1_m)) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "dynamic_obstacles[%d] is [%g, %g) x [%g, %g); it must be finite with x0 < x1 and "
          "y0 < y1",
          k, d.x0_m, d.x1_m, d.y0_m, d.y1_m));
    }
    if (d.at_iteration < 0) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "dynamic_obstacles[%d].at_iteration is %d; it must be >= 0", k, d.at_iteration));
    }
  }
  return absl::OkStatus();
}

EdgeSampleBound ProjectEdgeSamples(PlannerAlgorithm algorithm, const RiskMap& map,
                                   const ModelParams& params, const Pose& start, const Pose& goal,
                                   const std::map<std::string, double>& planner_params) {
  EdgeSampleBound b;
  double z_low = std::min({map.terrain_min_m(), start.z, goal.z});
  double z_high = std::max({map.terrain_max_m() + params.max_agl_m, start.z, goal.z});
  b.step_m = params.sample_step_m;
  for (const PlannerParamInfo& info : PlannerParams(algorithm)) {
    auto given = planner_params.find(info.name);
    const double value = given != planner_params.end() ? given->second : info.default_value;
    // 0 means "no fixed altitude" for both.
    if ((info.name == "flight_altitude_m" || info.name == "fixed_altitude_m") && value > 0.0) {
      z_low = std::min(z_low, value);
      z_high = std::max(z_high, value);
    }
    if (info.name == "risk_step_m" && value > 0.0) b.step_m = std::min(b.step_m, value);
  }
  const double r = params.GroundTurnRadius();
  b.map_diagonal_m = std::hypot(map.width_m(), map.height_m());
  b.climb_m = z_high - z_low;
  const double planar_m = b.map_diagonal_m + (2.0 + 4.0 * kPi) * r;
  const double spiral_m = b.climb_m / std::tan(params.GroundClimbAngle()) + kTwoPi * r;
  b.length_m = std::hypot(std::max(planar_m, spiral_m), b.climb_m);
  const int64_t parts = PartCount(b.length_m, b.step_m);
  b.samples = parts >= kMaxPartCount - 2 ? kMaxPartCount : parts + 2;
  return b;
}

absl::Status CheckEdgeSampleBound(PlannerAlgorithm algorithm, const RiskMap& map,
                                  const ModelParams& params, const Pose& start, const Pose& goal,
                                  const std::map<std::string, double>& planner_params,
                                  int64_t max_edge_samples, std::string_view limit_source) {
  const EdgeSampleBound b = ProjectEdgeSamples(algorithm, map, params, start, goal, planner_params);
  if (b.samples <= max_edge_samples) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrFormat(
      "an edge of a %s plan on map '%s' may need %d samples: up to %.1f m long (the map's "
      "diagonal %.1f m, %s %g, climbs of up to %.1f m at %s %g) sampled "
      "every %g m (sample_step_m%s); the limit is %d samples per edge%s",
      PlannerAlgorithmName(algorithm), map.name(), b.samples, b.length_m, b.map_diagonal_m,
      // In a wind the manoeuvres use R_w and gamma_w (spec section 5).
      params.Calm() ? "turn_radius_m" : "turn_radius_m widened by the wind to",
      params.GroundTurnRadius(), b.climb_m,
      params.Calm() ? "max_climb_rad" : "max_climb_rad flattened by the wind to",
      params.GroundClimbAngle(), b.step_m,
      algorithm == PlannerAlgorithm::kGenetic ? " or risk_step_m" : "", max_edge_samples,
      limit_source.empty() ? std::string() : absl::StrFormat(" (%s)", std::string(limit_source))));
}

absl::Status CheckEdgeSamples(PlannerAlgorithm algorithm, const PlanningProblem& problem,
                              const PlanOptions& options) {
  if (problem.model == nullptr) return absl::InvalidArgumentError("planning problem has no model");
  return CheckEdgeSampleBound(algorithm, problem.model->map(), problem.model->params(),
                              problem.start, problem.goal, options.params,
                              options.max_edge_samples);
}

}  // namespace riskplan
