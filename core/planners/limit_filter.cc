#include "core/planners/limit_filter.h"

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "core/flight/trajectory.h"

namespace riskplan {

namespace {

bool SameWaypoints(const std::vector<Pose>& a, const std::vector<Pose>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    if (a[i].x != b[i].x || a[i].y != b[i].y || a[i].z != b[i].z || a[i].theta != b[i].theta) {
      return false;
    }
  }
  return true;
}

class Filter {
 public:
  Filter(const PlanningProblem& problem, const FlightLimits& limits, RiskEvaluator* evaluator,
         const ImprovementCallback& on_improvement)
      : problem_(problem), limits_(limits), evaluator_(evaluator), out_(on_improvement) {}

  // Checks one reported trajectory; passes it on when it improves.
  void Offer(const PlanImprovement& improvement) {
    if (!error_.ok()) return;
    ++summary_.candidates;
    absl::StatusOr<LimitCheck> check =
        CheckTrajectoryLimits(*problem_.model, improvement.waypoints, limits_, evaluator_);
    if (!check.ok()) {
      error_ = check.status();
      return;
    }
    if (improvement.replanned) {
      // The problem changed (HARMONIC): what was found before no longer counts.
      best_.reset();
      front_.clear();
    }
    if (check->admissible) Note(*check);
    if (!check->meets) {
      ++summary_.rejected;
      return;
    }
    PlanImprovement out = improvement;
    out.flight_time_s = check->flight_time_s;
    if (limits_.pareto) {
      AddToFront(&front_, FrontPoint{.waypoints = improvement.waypoints,
                                     .risk = out.risk,
                                     .length_m = out.length_m,
                                     .flight_time_s = out.flight_time_s,
                                     .found_at_s = out.elapsed_s,
                                     .found_at_iteration = out.iterations});
    }
    if (!improvement.replanned && best_.has_value() && !Better(out, *best_)) return;
    if (limits_.pareto) out.front = front_;
    best_ = out;
    last_waypoints_ = improvement.waypoints;
    if (out_) out_(out);
  }

  absl::StatusOr<PlanResult> Finish(absl::StatusOr<PlanResult> result) {
    if (!result.ok()) return result;
    if (!error_.ok()) return error_;
    // A final best the algorithm did not report as an improvement.
    if (result->best.has_value() && !SameWaypoints(result->best->waypoints, last_waypoints_) &&
        !SameWaypoints(result->best->waypoints, last_offered_)) {
      Offer(*result->best);
      if (!error_.ok()) return error_;
    }
    const bool had = result->best.has_value();
    result->best = best_;
    result->front = front_;
    if (had && !best_.has_value()) {
      if (result->reason == StopReason::kBudgetExhausted ||
          result->reason == StopReason::kConverged) {
        result->reason = StopReason::kNoSolution;
      }
      summary_.note = Note();
    }
    result->limits = summary_;
    return result;
  }

  void Remember(const PlanImprovement& improvement) { last_offered_ = improvement.waypoints; }

 private:
  bool Better(const PlanImprovement& a, const PlanImprovement& b) const {
    if (limits_.objective == PlanObjective::kMinTime) {
      if (a.flight_time_s != b.flight_time_s) return a.flight_time_s < b.flight_time_s;
      return a.risk < b.risk;
    }
    return a.risk < b.risk;
  }

  static void Min(std::optional<double>* slot, double value) {
    if (!slot->has_value() || value < **slot) *slot = value;
  }

  void Note(const LimitCheck& check) {
    Min(&summary_.fastest_flight_time_s, check.flight_time_s);
    Min(&summary_.shortest_length_m, check.length_m);
    Min(&summary_.lowest_risk, check.risk);
    Min(&summary_.lowest_risk_per_flight_hour, RiskPerFlightHour(check.risk, check.flight_time_s));
  }

  // Why no trajectory met the limits, from the best values found.
  std::string Note() const {
    if (!summary_.fastest_flight_time_s.has_value()) {
      return absl::StrFormat(
          "no admissible trajectory: the %d trajectories found were not admissible",
          summary_.candidates);
    }
    std::vector<std::string> parts;
    if (limits_.max_flight_time_s > 0.0 &&
        *summary_.fastest_flight_time_s > limits_.max_flight_time_s) {
      parts.push_back(absl::StrFormat(
          "no trajectory within the endurance (max_flight_time_s = %g s): the fastest trajectory "
          "found flies %.1f s",
          limits_.max_flight_time_s, *summary_.fastest_flight_time_s));
    }
    if (limits_.max_length_m > 0.0 && *summary_.shortest_length_m > limits_.max_length_m) {
      parts.push_back(absl::StrFormat(
          "no trajectory within max_length_m = %g m: the shortest trajectory found is %.1f m",
          limits_.max_length_m, *summary_.shortest_length_m));
    }
    if (limits_.max_risk > 0.0 && *summary_.lowest_risk > limits_.max_risk) {
      parts.push_back(absl::StrFormat(
          "no trajectory meets the target level of safety (max_risk = %g per flight): the "
          "lowest risk found is %.4g",
          limits_.max_risk, *summary_.lowest_risk));
    }
    if (limits_.max_risk_per_flight_hour > 0.0 &&
        *summary_.lowest_risk_per_flight_hour > limits_.max_risk_per_flight_hour) {
      parts.push_back(absl::StrFormat(
          "no trajectory meets the target level of safety (max_risk_per_flight_hour = %g): the "
          "lowest risk per flight hour found is %.4g",
          limits_.max_risk_per_flight_hour, *summary_.lowest_risk_per_flight_hour));
    }
    if (parts.empty()) {
      parts.push_back(absl::StrFormat(
          "no trajectory meets all the limits together (each alone was met by some of the %d "
          "trajectories found: fastest %.1f s, shortest %.1f m, lowest risk %.4g, lowest risk "
          "per flight hour %.4g)",
          summary_.candidates, *summary_.fastest_flight_time_s, *summary_.shortest_length_m,
          *summary_.lowest_risk, *summary_.lowest_risk_per_flight_hour));
    }
    return absl::StrJoin(parts, "; ");
  }

  const PlanningProblem& problem_;
  const FlightLimits& limits_;
  RiskEvaluator* evaluator_;
  const ImprovementCallback& out_;
  absl::Status error_;
  std::optional<PlanImprovement> best_;
  std::vector<FrontPoint> front_;
  std::vector<Pose> last_waypoints_;
  std::vector<Pose> last_offered_;
  LimitSummary summary_;
};

}  // namespace

absl::StatusOr<PlanResult> PlanWithLimits(
    const std::function<absl::StatusOr<PlanResult>(const ImprovementCallback&)>& algorithm,
    const PlanningProblem& problem, const PlanOptions& options, RiskEvaluator* evaluator,
    const ImprovementCallback& on_improvement) {
  if (!options.limits.Active()) return algorithm(on_improvement);
  if (absl::Status s = CheckFlightLimits(options.limits); !s.ok()) return s;
  if (problem.model == nullptr) return absl::InvalidArgumentError("the problem has no model");
  Filter filter(problem, options.limits, evaluator, on_improvement);
  return filter.Finish(algorithm([&](const PlanImprovement& improvement) {
    filter.Remember(improvement);
    filter.Offer(improvement);
  }));
}

}  // namespace riskplan
