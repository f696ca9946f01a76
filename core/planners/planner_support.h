// What the RRT, GENETIC and HARMONIC planners share: parameters by name,
// budget and cancellation, the admissible altitude band of a cell, and the
// exact report of a trajectory.
#ifndef RISKPLAN_CORE_PLANNERS_PLANNER_SUPPORT_H_
#define RISKPLAN_CORE_PLANNERS_PLANNER_SUPPORT_H_

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/planners/planner.h"
#include "core/risk/risk_evaluator.h"
#include "core/risk/risk_model.h"

namespace riskplan {

// The parameter values of one Plan() call: the defaults of `info`, overridden
// by the request's. Unknown names and values that are not finite or outside
// [min_value, max_value] are InvalidArgument errors naming the parameter.
class PlannerParamValues {
 public:
  static absl::StatusOr<PlannerParamValues> Parse(std::string_view algorithm,
                                                  const std::vector<PlannerParamInfo>& info,
                                                  const std::map<std::string, double>& given);

  // REQUIRES: `name` is one of the names of `info`.
  double Get(std::string_view name) const;

 private:
  std::map<std::string, double, std::less<>> values_;
};

// OK when max_time_s >= 0 and finite, max_iterations >= 0 and not both are 0;
// else InvalidArgument naming the budget.
absl::Status CheckBudget(const PlannerBudget& budget);

// The wall clock, iteration budget and cancellation of one run.
class RunLimits {
 public:
  RunLimits(const PlannerBudget& budget, const CancellationToken& cancel)
      : budget_(budget), cancel_(cancel), start_(std::chrono::steady_clock::now()) {}

  // The token and the time budget as the StopCondition that long loops poll
  // inside an iteration (never reached by an iteration budget alone, so a
  // run bounded by iterations stays reproducible).
  StopCondition Stop() const {
    std::optional<std::chrono::steady_clock::time_point> deadline;
    if (budget_.max_time_s > 0.0) {
      deadline = start_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                              std::chrono::duration<double>(budget_.max_time_s));
    }
    return StopCondition(&cancel_, nullptr, deadline);
  }
  // The token alone, for work that must still finish once the time is up
  // (HARMONIC's report of its last descent).
  StopCondition CancelStop() const { return StopCondition(&cancel_); }

  double Elapsed() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  bool Cancelled() const { return cancel_.IsCancelled(); }
  bool OutOfTime() const { return budget_.max_time_s > 0.0 && Elapsed() >= budget_.max_time_s; }
  // True when `iterations` reached the iteration budget (never without one).
  bool OutOfIterations(int64_t iterations) const {
    return budget_.max_iterations > 0 && iterations >= budget_.max_iterations;
  }
  int64_t max_iterations() const { return budget_.max_iterations; }

 private:
  const PlannerBudget budget_;
  const CancellationToken& cancel_;
  const std::chrono::steady_clock::time_point start_;
};

// What the run of a seed planner (the RunT of PlanSeedRun) keeps of its
// Plan() call. Each RunT derives from it and reads these as its own members,
// so that the three do not each declare and initialise the same six; the
// limits are thus constructed, and the run's clock started, before the
// planner's own state.
class SeedRunBase {
 protected:
  SeedRunBase(const PlanningProblem& problem, const PlanOptions& options, RiskEvaluator* evaluator,
              const CancellationToken& cancel, const ImprovementCallback& on_improvement)
      : problem_(problem),
        model_(*problem.model),
        options_(options),
        evaluator_(evaluator),
        limits_(options.budget, cancel),
        on_improvement_(on_improvement) {}

  const PlanningProblem& problem_;
  const RiskModel& model_;
  const PlanOptions& options_;
  RiskEvaluator* evaluator_;
  RunLimits limits_;
  const ImprovementCallback& on_improvement_;
};

// What a planner's long loop returns when the run's StopCondition is reached
// in the middle of an iteration: the run then ends as it would have at the
// next check of its budget (the iteration is dropped, the best trajectory so
// far stands), with StopReason kCancelled when the token was cancelled and
// kBudgetExhausted (or kNoSolution) when the time ran out.
absl::Status RunStopped();
bool IsRunStopped(const absl::Status& status);

// The admissible altitudes of cell (i, j) under spec section 6:
// [SafeAltitude, terrain + max_agl]. False for a no-fly cell, a cell outside
// the map, and a cell whose band is empty.
bool CellBand(const RiskModel& model, int i, int j, double* low_m, double* high_m);

// Per map cell (index j * nx + i): 1 where flight is possible. With
// `flight_altitude_m` = 0, where the band of CellBand is not empty; otherwise
// where that altitude lies in the band ("terrain above the flight altitude",
// and no-fly cells, are obstacles).
std::vector<uint8_t> FlyableCells(const RiskModel& model, double flight_altitude_m);

// The exact report of waypoints joined by Dubins-airplane manoeuvres:
// EvaluateTrajectory's risk and length through `evaluator`. nullopt when the
// trajectory is not admissible. Fails when the evaluator does, or with
// RunStopped() once `stop` is reached.
absl::StatusOr<std::optional<PlanImprovement>> EvaluateWaypoints(const RiskModel& model,
                                                                 std::vector<Pose> waypoints,
                                                                 RiskEvaluator* evaluator,
                                                                 const StopCondition& stop = {});

// InvalidArgument when `pose` ("start" or "goal") lies within `clearance_m`
// (horizontally) of one of `points`, naming the point; else OK.
absl::Status CheckPoseClearance(const Pose& pose, const char* which,
                                const std::vector<Point2>& points, double clearance_m);

// The checks a seed planner (RRT, GENETIC, HARMONIC) makes before it plans, in
// this order: start and goal (CheckEndpoints), the budget, the request's
// obstacles (CheckRequestObstacles), its parameters (parsed against `info`),
// the samples of its edges (CheckEdgeSamples) and the clearance of start and
// goal from the request's obstacle points by its "clearance_m" parameter.
// Returns the parsed parameters.
absl::StatusOr<PlannerParamValues> PrepareSeedPlan(PlannerAlgorithm algorithm,
                                                   const std::vector<PlannerParamInfo>& info,
                                                   const PlanningProblem& problem,
                                                   const PlanOptions& options);

// A seed planner's Plan(), its AlgorithmEntry::plan: PrepareSeedPlan against
// PlannerParams(kAlgorithm), then one `RunT` (the planner's per-call state,
// constructed from the problem, options, parsed parameters, evaluator, token
// and callback) executed with `evaluator`, or with a DirectRiskEvaluator of
// its own when that is null.
template <typename RunT, PlannerAlgorithm kAlgorithm>
absl::StatusOr<PlanResult> PlanSeedRun(RiskEvaluator* evaluator, const PlanningProblem& problem,
                                       const PlanOptions& options, const CancellationToken& cancel,
                                       const ImprovementCallback& on_improvement) {
  absl::StatusOr<PlannerParamValues> params =
      PrepareSeedPlan(kAlgorithm, PlannerParams(kAlgorithm), problem, options);
  if (!params.ok()) return params.status();
  DirectRiskEvaluator direct;
  RunT run(problem, options, *params, evaluator != nullptr ? evaluator : &direct, cancel,
           on_improvement);
  return run.Execute();
}

}  // namespace riskplan

#endif  // RISKPLAN_CORE_PLANNERS_PLANNER_SUPPORT_H_
