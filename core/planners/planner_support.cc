#include "core/planners/planner_support.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/cord.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "core/base/check.h"
#include "core/flight/trajectory.h"

namespace riskplan {

absl::StatusOr<PlannerParamValues> PlannerParamValues::Parse(
    std::string_view algorithm, const std::vector<PlannerParamInfo>& info,
    const std::map<std::string, double>& given) {
  PlannerParamValues out;
  for (const PlannerParamInfo& i : info) out.values_[i.name] = i.default_value;
  for (const auto& [name, value] : given) {
    // Captured by an init-capture: clang before 16 cannot capture a
    // structured binding (the sanitizer builds use clang 14).
    auto it = std::find_if(info.begin(), info.end(),
                           [&name = name](const PlannerParamInfo& i) { return i.name == name; });
    if (it == info.end()) {
      std::vector<std::string> names;
      for (const PlannerParamInfo& i : info) names.push_back(i.name);
      return absl::InvalidArgumentError(
          absl::StrFormat("unknown planner parameter '%s' for %s; known: %s", name,
                          std::string(algorithm), absl::StrJoin(names, ", ")));
    }
    if (!std::isfinite(value) || value < it->min_value || value > it->max_value) {
      return absl::InvalidArgumentError(
          absl::StrFormat("planner parameter '%s' has value %g; it must be in [%g, %g]", name,
                          value, it->min_value, it->max_value));
    }
    out.values_[name] = value;
  }
  return out;
}

double PlannerParamValues::Get(std::string_view name) const {
  auto it = values_.find(name);
  RISKPLAN_DCHECK(it != values_.end());
  return it == values_.end() ? std::nan("") : it->second;
}

absl::Status CheckBudget(const PlannerBudget& b) {
  if (!(b.max_time_s >= 0.0) || !std::isfinite(b.max_time_s) || b.max_iterations < 0 ||
      (b.max_time_s == 0.0 && b.max_iterations == 0)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "budget: max_time_s (%g) and max_iterations (%d) must be >= 0 and not both 0", b.max_time_s,
        b.max_iterations));
  }
  return absl::OkStatus();
}

namespace {

// Marks the status of a stopped run apart from any error an evaluator could
// return with the same code.
constexpr char kRunStoppedPayload[] = "riskplan/run-stopped";

}  // namespace

absl::Status RunStopped() {
  absl::Status status = absl::CancelledError("the run's budget ended or it was cancelled");
  status.SetPayload(kRunStoppedPayload, absl::Cord("1"));
  return status;
}

bool IsRunStopped(const absl::Status& status) {
  return status.GetPayload(kRunStoppedPayload).has_value();
}

bool CellBand(const RiskModel& model, int i, int j, double* low_m, double* high_m) {
  const RiskMap& map = model.map();
  if (!map.Contains(i, j) || map.nofly(i, j)) return false;
  // The same arithmetic as RiskModel::CheckConfiguration, so that a z inside
  // [low, high] passes it (z > terrain holds because min_agl >= 0 and the
  // band is checked to lie above the terrain).
  const double terrain = map.terrain(i, j);
  const double low = model.SafeAltitude(i, j);
  // Near the edges the band ends lower, where a fall's impact window would
  // reach past the map at some heading (spec version 2).
  const double high =
      std::min(terrain + model.params().max_agl_m, terrain + model.WindowCeilingAgl(i, j));
  if (!(low <= high) || !(high > terrain)) return false;
  *low_m = low > terrain ? low : std::nextafter(terrain, high);
  *high_m = high;
  return *low_m <= *high_m;
}

std::vector<uint8_t> FlyableCells(const RiskModel& model, double flight_altitude_m) {
  const RiskMap& map = model.map();
  std::vector<uint8_t> out(static_cast<size_t>(map.nx()) * map.ny(), 0);
  for (int j = 0; j < map.ny(); ++j) {
    for (int i = 0; i < map.nx(); ++i) {
      double low = 0.0;
      double high = 0.0;
      if (!CellBand(model, i, j, &low, &high)) continue;
      if (flight_altitude_m > 0.0 && !(flight_altitude_m >= low && flight_altitude_m <= high)) {
        continue;
      }
      out[map.Index(i, j)] = 1;
    }
  }
  return out;
}

absl::StatusOr<std::optional<PlanImprovement>> EvaluateWaypoints(const RiskModel& model,
                                                                 std::vector<Pose> waypoints,
                                                                 RiskEvaluator* evaluator,
                                                                 const StopCondition& stop) {
  auto pieces = PiecesFromWaypoints(waypoints, model.params());
  if (!pieces.ok()) return pieces.status();
  auto eval = EvaluateTrajectory(model, *pieces, {}, evaluator, stop);
  // EvaluateTrajectory fails with Cancelled only when `stop` is reached.
  if (!eval.ok() && stop.Reached()) return RunStopped();
  if (!eval.ok()) return eval.status();
  if (!eval->admissible) return std::optional<PlanImprovement>();
  PlanImprovement out;
  out.waypoints = std::move(waypoints);
  out.risk = eval->risk;
  out.length_m = eval->length_m;
  return std::optional<PlanImprovement>(std::move(out));
}

absl::Status CheckPoseClearance(const Pose& pose, const char* which,
                                const std::vector<Point2>& points, double clearance_m) {
  for (size_t k = 0; k < points.size(); ++k) {
    const double d = std::hypot(points[k].x - pose.x, points[k].y - pose.y);
    if (d <= clearance_m) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "%s pose (%.1f, %.1f) is %.1f m from obstacle_points[%d] at (%.1f, %.1f), within "
          "clearance_m = %g m",
          which, pose.x, pose.y, d, k, points[k].x, points[k].y, clearance_m));
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<PlannerParamValues> PrepareSeedPlan(PlannerAlgorithm algorithm,
                                                   const std::vector<PlannerParamInfo>& info,
                                                   const PlanningProblem& problem,
                                                   const PlanOptions& options) {
  if (absl::Status s = CheckEndpoints(problem); !s.ok()) return s;
  if (absl::Status s = CheckBudget(options.budget); !s.ok()) return s;
  if (absl::Status s = CheckRequestObstacles(algorithm, options); !s.ok()) return s;
  auto params = PlannerParamValues::Parse(PlannerAlgorithmName(algorithm), info, options.params);
  if (!params.ok()) return params.status();
  if (absl::Status s = CheckEdgeSamples(algorithm, problem, options); !s.ok()) return s;
  const double clearance = params->Get("clearance_m");
  for (auto [pose, which] : {std::pair{&problem.start, "start"}, {&problem.goal, "goal"}}) {
    if (absl::Status s = CheckPoseClearance(*pose, which, options.obstacle_points, clearance);
        !s.ok()) {
      return s;
    }
  }
  return params;
}

}  // namespace riskplan
