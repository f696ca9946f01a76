#include "core/planners/limit_filter.h"

#include <cstdint>
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
    absl::StatusOr<LimitCheck> check = Check(improvement);
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

  bool HasBest() const { return best_.has_value(); }

  // A pass's final best, when it was not reported as an improvement.
  void OfferFinal(const PlanImprovement& best) {
    if (SameWaypoints(best.waypoints, last_waypoints_) ||
        SameWaypoints(best.waypoints, last_offered_)) {
      return;
    }
    last_offered_ = best.waypoints;
    Offer(best);
  }

 private:
  // The exact numbers of a reported trajectory. In still air they need no
  // evaluation: a planner's risk and length are EvaluateTrajectory's bit for
  // bit, its trajectories are admissible, and the flight time is
  // FlightTimeS(length, airspeed) (spec section 4, version 2). In a wind the
  // time depends on the ground speed along the track: EvaluateTrajectory.
  absl::StatusOr<LimitCheck> Check(const PlanImprovement& improvement) const {
    const RiskModel& model = *problem_.model;
    if (!model.params().Calm()) {
      return CheckTrajectoryLimits(model, improvement.waypoints, limits_, evaluator_);
    }
    return CheckNumbers(improvement.risk, improvement.length_m,
                        FlightTimeS(improvement.length_m, model.params().airspeed_mps), limits_);
  }

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

std::vector<PlanOptions> LimitPasses(PlannerAlgorithm algorithm, const PlanOptions& options) {
  const FlightLimits& l = options.limits;
  const bool trades_time = l.max_flight_time_s > 0.0 || l.max_length_m > 0.0 ||
                           l.objective == PlanObjective::kMinTime || l.pareto;
  if (algorithm != PlannerAlgorithm::kRiskRrtStar || !trades_time ||
      options.params.count("guide_cell_m") > 0) {
    return {options};
  }
  if (options.budget.max_iterations == 1) return {options};  // one iteration: no parts
  PlanOptions first = options;
  PlanOptions second = options;
  // MIN_RISK without the front: a guided probe of a quarter of the budget,
  // then three quarters for the pass the probe chooses (PlanWithLimits);
  // otherwise half unguided, half guided.
  const bool probe = l.objective == PlanObjective::kMinRisk && !l.pareto;
  const double share = probe ? 0.25 : 0.5;
  if (!probe) first.params["guide_cell_m"] = 0.0;
  if (probe) second.params["guide_cell_m"] = 0.0;
  first.budget.max_time_s = options.budget.max_time_s * share;
  second.budget.max_time_s = options.budget.max_time_s - first.budget.max_time_s;
  first.budget.max_iterations =
      static_cast<int64_t>(static_cast<double>(options.budget.max_iterations) * share);
  second.budget.max_iterations = options.budget.max_iterations - first.budget.max_iterations;
  return {first, second};
}

absl::StatusOr<PlanResult> PlanWithLimits(PlannerAlgorithm algorithm, const AlgorithmRun& run,
                                          const PlanningProblem& problem,
                                          const PlanOptions& options, RiskEvaluator* evaluator,
                                          const ImprovementCallback& on_improvement) {
  if (!options.limits.Active()) return run(options, on_improvement);
  if (absl::Status s = CheckFlightLimits(options.limits); !s.ok()) return s;
  if (problem.model == nullptr) return absl::InvalidArgumentError("the problem has no model");
  Filter filter(problem, options.limits, evaluator, on_improvement);
  std::vector<PlanOptions> passes = LimitPasses(algorithm, options);
  // The guided probe (MIN_RISK): when one of its trajectories meets the
  // limits the guided search goes on, on a new tree with the same seed (which
  // grows the probe's tree again and further); when none does, the rest of
  // the budget goes to the unguided sweep.
  const bool probe = passes.size() == 2 && passes[0].params.count("guide_cell_m") == 0;
  PlanResult total;
  double elapsed = 0.0;
  int64_t iterations = 0;
  for (size_t k = 0; k < passes.size(); ++k) {
    absl::StatusOr<PlanResult> pass = run(passes[k], [&](const PlanImprovement& improvement) {
      if (elapsed == 0.0 && iterations == 0) {
        filter.Remember(improvement);
        filter.Offer(improvement);
        return;
      }
      PlanImprovement shifted = improvement;
      shifted.elapsed_s += elapsed;
      shifted.iterations += iterations;
      filter.Remember(shifted);
      filter.Offer(shifted);
    });
    if (!pass.ok()) return filter.Finish(std::move(pass));
    // The result of the passes: the last one's, with the counts of all.
    std::optional<PlanImprovement> best = total.best;
    if (pass->best.has_value()) {
      pass->best->elapsed_s += elapsed;
      pass->best->iterations += iterations;
      best = pass->best;
    }
    const uint64_t evaluated = total.configurations_evaluated + pass->configurations_evaluated;
    elapsed += pass->elapsed_s;
    iterations += pass->iterations;
    total = *std::move(pass);
    total.best = best;
    total.elapsed_s = elapsed;
    total.iterations = iterations;
    total.configurations_evaluated = evaluated;
    if (total.reason == StopReason::kCancelled) break;
    // The pass's final best goes through the filter now (the next pass
    // would hide it from Finish).
    if (k + 1 < passes.size() && total.best.has_value()) filter.OfferFinal(*total.best);
    if (k == 0 && probe && filter.HasBest()) passes[1].params.erase("guide_cell_m");
  }
  // Some pass found a trajectory: the run has one.
  if (total.reason == StopReason::kNoSolution && total.best.has_value()) {
    total.reason = StopReason::kBudgetExhausted;
  }
  return filter.Finish(std::move(total));
}

}  // namespace riskplan
