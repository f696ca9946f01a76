// Limits a plan must meet and what it optimises (issue 35): endurance (a
// maximum flight time and length), a target level of safety (a maximum risk
// per flight or per flight hour), the objective (least risk or least time)
// and the risk-time front.
//
// Every planner honours them the same way, through LimitFilter, which
// MakePlanner's planners put between the algorithm and the caller: each
// trajectory the algorithm reports is evaluated once with EvaluateTrajectory
// (its exact risk and flight time, the ground speed in wind), checked
// against the limits, and passed on only when it meets them and improves the
// objective. So no planner ever reports or returns a trajectory that breaks a
// limit; when none of the trajectories it found meets them the plan ends with
// NO_SOLUTION and a note that says which limit and the best value found
// (e.g. the fastest flight time).
#ifndef RISKPLAN_CORE_PLANNERS_FLIGHT_LIMITS_H_
#define RISKPLAN_CORE_PLANNERS_FLIGHT_LIMITS_H_

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/risk/risk_evaluator.h"
#include "core/risk/risk_model.h"

namespace riskplan {

enum class PlanObjective {
  kMinRisk = 0,  // the lowest-risk trajectory within the limits (the default)
  kMinTime = 1,  // the quickest trajectory within the limits
};

// "MIN_RISK", "MIN_TIME".
std::string_view PlanObjectiveName(PlanObjective objective);

struct FlightLimits {
  // Each limit is off when 0; a set limit is finite and > 0.
  double max_flight_time_s = 0.0;         // endurance, s (ground speed in wind)
  double max_length_m = 0.0;              // 3-D length, m
  double max_risk = 0.0;                  // expected casualties per flight
  double max_risk_per_flight_hour = 0.0;  // risk / (flight time / 3600)
  PlanObjective objective = PlanObjective::kMinRisk;
  // Keep the set of mutually non-dominated (risk, flight time) trajectories
  // found (PlanImprovement::front, PlanResult::front).
  bool pareto = false;

  // True when anything differs from the defaults (no limit, MIN_RISK, no
  // front): only then does the filter run.
  bool Active() const;
};

// InvalidArgument naming the field (e.g. "limits.max_flight_time_s") when a
// limit is negative or not finite, or the objective is not one of the enum.
absl::Status CheckFlightLimits(const FlightLimits& limits);

// One trajectory of the front, with EvaluateTrajectory's exact numbers.
struct FrontPoint {
  std::vector<Pose> waypoints;
  double risk = 0.0;
  double length_m = 0.0;
  double flight_time_s = 0.0;
  double found_at_s = 0.0;
  int64_t found_at_iteration = 0;
};

// The exact numbers of a trajectory and whether they meet the limits.
struct LimitCheck {
  double risk = 0.0;
  double length_m = 0.0;
  double flight_time_s = 0.0;
  bool admissible = false;  // spec section 6
  bool meets = false;       // admissible and within every limit
  // The first limit broken, e.g. "max_flight_time_s"; empty when none.
  std::string broken;
};

// Checks `waypoints` against `limits` (EvaluateTrajectory, so in wind the
// flight time uses the ground speed).
absl::StatusOr<LimitCheck> CheckTrajectoryLimits(const RiskModel& model,
                                                 const std::vector<Pose>& waypoints,
                                                 const FlightLimits& limits,
                                                 RiskEvaluator* evaluator = nullptr);

// The check of an admissible trajectory's exact numbers (what
// CheckTrajectoryLimits does after its evaluation).
LimitCheck CheckNumbers(double risk, double length_m, double flight_time_s,
                        const FlightLimits& limits);

// Adds a point to a non-dominated front (risk, flight time both minimised):
// dropped when a point of the front is no worse in both and better in one
// (or equal in both); otherwise inserted, removing the points it dominates.
// The front stays sorted by increasing flight time (so decreasing risk).
// True when the front changed.
bool AddToFront(std::vector<FrontPoint>* front, FrontPoint point);

// True when no point of `front` dominates another (and none are equal in both).
bool NonDominated(const std::vector<FrontPoint>& front);

// The note of a plan whose trajectories all broke the limits: which limit,
// the value found closest to it (e.g. "no trajectory within the endurance of
// 200 s: the fastest trajectory found flies 417.3 s").
struct LimitSummary {
  int64_t candidates = 0;  // trajectories the algorithm reported
  int64_t rejected = 0;    // ... that broke a limit
  std::optional<double> fastest_flight_time_s;  // of the admissible candidates
  std::optional<double> shortest_length_m;
  std::optional<double> lowest_risk;
  std::optional<double> lowest_risk_per_flight_hour;
  std::string note;  // set when no candidate met the limits
};

}  // namespace riskplan

#endif  // RISKPLAN_CORE_PLANNERS_FLIGHT_LIMITS_H_
