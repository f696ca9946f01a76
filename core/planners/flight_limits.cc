#include "core/planners/flight_limits.h"

#include <cmath>
#include <utility>

#include "absl/strings/str_format.h"
#include "core/flight/trajectory.h"

namespace riskplan {

std::string_view PlanObjectiveName(PlanObjective objective) {
  switch (objective) {
    case PlanObjective::kMinRisk:
      return "MIN_RISK";
    case PlanObjective::kMinTime:
      return "MIN_TIME";
  }
  return "UNKNOWN";
}

bool FlightLimits::Active() const {
  return max_flight_time_s != 0.0 || max_length_m != 0.0 || max_risk != 0.0 ||
         max_risk_per_flight_hour != 0.0 || objective != PlanObjective::kMinRisk || pareto;
}

absl::Status CheckFlightLimits(const FlightLimits& limits) {
  for (auto [name, value] : {std::pair{"max_flight_time_s", limits.max_flight_time_s},
                             {"max_length_m", limits.max_length_m},
                             {"max_risk", limits.max_risk},
                             {"max_risk_per_flight_hour", limits.max_risk_per_flight_hour}}) {
    if (!std::isfinite(value) || value < 0.0) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "limits.%s is %g; it must be finite and >= 0 (0: no limit)", name, value));
    }
  }
  if (limits.objective != PlanObjective::kMinRisk && limits.objective != PlanObjective::kMinTime) {
    return absl::InvalidArgumentError(
        absl::StrFormat("limits.objective is %d; it must be MIN_RISK or MIN_TIME",
                        static_cast<int>(limits.objective)));
  }
  return absl::OkStatus();
}

absl::StatusOr<LimitCheck> CheckTrajectoryLimits(const RiskModel& model,
                                                 const std::vector<Pose>& waypoints,
                                                 const FlightLimits& limits,
                                                 RiskEvaluator* evaluator) {
  auto pieces = PiecesFromWaypoints(waypoints, model.params());
  if (!pieces.ok()) return pieces.status();
  auto eval = EvaluateTrajectory(model, *pieces, {}, evaluator);
  if (!eval.ok()) return eval.status();
  if (!eval->admissible) {
    LimitCheck out;
    out.risk = eval->risk;
    out.length_m = eval->length_m;
    out.flight_time_s = eval->flight_time_s;
    out.broken = "admissibility";
    return out;
  }
  return CheckNumbers(eval->risk, eval->length_m, eval->flight_time_s, limits);
}

LimitCheck CheckNumbers(double risk, double length_m, double flight_time_s,
                        const FlightLimits& limits) {
  LimitCheck out;
  out.risk = risk;
  out.length_m = length_m;
  out.flight_time_s = flight_time_s;
  out.admissible = true;
  if (limits.max_flight_time_s > 0.0 && out.flight_time_s > limits.max_flight_time_s) {
    out.broken = "max_flight_time_s";
  } else if (limits.max_length_m > 0.0 && out.length_m > limits.max_length_m) {
    out.broken = "max_length_m";
  } else if (limits.max_risk > 0.0 && out.risk > limits.max_risk) {
    out.broken = "max_risk";
  } else if (limits.max_risk_per_flight_hour > 0.0 &&
             RiskPerFlightHour(out.risk, out.flight_time_s) > limits.max_risk_per_flight_hour) {
    out.broken = "max_risk_per_flight_hour";
  }
  out.meets = out.broken.empty();
  return out;
}

namespace {

// a dominates b: no worse in both, better in one, or equal in both.
bool Dominates(const FrontPoint& a, const FrontPoint& b) {
  return a.risk <= b.risk && a.flight_time_s <= b.flight_time_s;
}

}  // namespace

bool AddToFront(std::vector<FrontPoint>* front, FrontPoint point) {
  for (const FrontPoint& p : *front) {
    if (Dominates(p, point)) return false;
  }
  std::vector<FrontPoint> kept;
  kept.reserve(front->size() + 1);
  bool placed = false;
  for (FrontPoint& p : *front) {
    if (Dominates(point, p)) continue;
    if (!placed && point.flight_time_s < p.flight_time_s) {
      kept.push_back(std::move(point));
      placed = true;
    }
    kept.push_back(std::move(p));
  }
  if (!placed) kept.push_back(std::move(point));
  *front = std::move(kept);
  return true;
}

bool NonDominated(const std::vector<FrontPoint>& front) {
  for (size_t i = 0; i < front.size(); ++i) {
    for (size_t j = 0; j < front.size(); ++j) {
      if (i != j && Dominates(front[i], front[j])) return false;
    }
  }
  return true;
}

}  // namespace riskplan
