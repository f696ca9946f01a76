// The Planner interface shared by every planner riskplan offers.
//
// A planner gets a problem (a RiskModel, i.e. map + parameters, and start and
// goal poses), a budget, a seed, a cancellation token and an improvement
// callback. It reports each better trajectory through the callback as it finds
// it, and returns the best one with the reason it stopped.
//
// Planners are single-threaded and deterministic: the same problem, options
// and seed give the same trajectory, bit for bit, whatever the machine load
// (budgets in wall time end a run at a different iteration, so only runs
// bounded by iterations are bit-for-bit reproducible).
#ifndef RISKPLAN_CORE_PLANNERS_PLANNER_H_
#define RISKPLAN_CORE_PLANNERS_PLANNER_H_

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/cancellation.h"
#include "core/base/geometry.h"
#include "core/planners/flight_limits.h"
#include "core/risk/risk_evaluator.h"
#include "core/risk/risk_model.h"

namespace riskplan {

enum class PlannerAlgorithm {
  kRiskRrtStar = 0,  // core/planners/risk_rrt_star.h
  kRrt = 1,          // core/planners/rrt_planner.h (seed 004)
  kGenetic = 2,      // core/planners/genetic_planner.h (seed 003)
  kHarmonic = 3,     // core/planners/harmonic_planner.h (seed 002)
};

// "RISK_RRT_STAR", "RRT", "GENETIC", "HARMONIC".
std::string_view PlannerAlgorithmName(PlannerAlgorithm algorithm);

struct PlanningProblem {
  std::shared_ptr<const RiskModel> model;  // map + parameters
  Pose start;
  Pose goal;
};

struct PlannerBudget {
  double max_time_s = 1.0;     // wall time; 0 means no limit
  int64_t max_iterations = 0;  // 0 means no limit
  // At least one of the two must be set: Plan() refuses a budget with neither
  // (CheckBudget, InvalidArgument).
};

// A point of the horizontal plane, map metres.
struct Point2 {
  double x = 0.0;
  double y = 0.0;
};

// An area that becomes an obstacle while a plan runs (seed 002's "obstacles
// discovered during computation"): from relaxation sweep `at_iteration` on,
// [x0_m, x1_m) x [y0_m, y1_m) in map metres is closed to flight. Deterministic
// because it is tied to the planner's iteration count, not to wall time.
struct DynamicObstacle {
  int64_t at_iteration = 0;  // >= 0; 0: present from the start
  double x0_m = 0.0;         // x0_m < x1_m
  double y0_m = 0.0;         // y0_m < y1_m
  double x1_m = 0.0;
  double y1_m = 0.0;
};

// Largest numbers of request-carried obstacles (CheckRequestObstacles).
inline constexpr size_t kMaxObstaclePoints = 100000;
inline constexpr size_t kMaxDynamicObstacles = 1000;

// Default of PlanOptions::max_edge_samples.
inline constexpr int64_t kDefaultMaxEdgeSamples = 1000000;

struct PlanOptions {
  PlannerBudget budget;
  uint64_t seed = 1;
  // Algorithm-specific parameters by name (see PlannerParamNames()); unknown
  // names are an error.
  std::map<std::string, double> params;
  // Keep the final tree (edges as polylines) in the result, for pictures.
  bool record_tree = false;
  // Obstacles carried by the request, on top of the map's own (no-fly cells,
  // terrain). Each point is a vertical column of unlimited height at (x, y):
  // the RRT, GENETIC and HARMONIC planners keep every edge or trajectory
  // sample farther than their parameter `clearance_m` from it horizontally.
  std::vector<Point2> obstacle_points;
  // Areas closed while the plan runs: HARMONIC only (see DynamicObstacle).
  std::vector<DynamicObstacle> dynamic_obstacles;
  // Most samples any piece a planner flies may need (CheckEdgeSamples): the
  // work of one edge, bounded before the plan starts.
  int64_t max_edge_samples = kDefaultMaxEdgeSamples;
  // Endurance, target level of safety, objective and front
  // (core/planners/flight_limits.h): honoured by every planner MakePlanner
  // makes.
  FlightLimits limits;
};

enum class StopReason {
  kBudgetExhausted = 0,  // time or iterations used up, a solution exists
  kConverged,            // the planner proved it cannot improve further
  kCancelled,            // the token was cancelled
  kNoSolution,           // the budget ended without any admissible trajectory
};

std::string_view StopReasonName(StopReason reason);

// One improved trajectory.
struct PlanImprovement {
  std::vector<Pose> waypoints;  // start ... goal, joined by Dubins-airplane manoeuvres
  double risk = 0.0;            // spec section 4, exactly what EvaluateTrajectory gives
  double length_m = 0.0;
  int64_t iterations = 0;
  int64_t tree_size = 0;
  double elapsed_s = 0.0;
  // True when the problem changed since the previous improvement (HARMONIC:
  // a dynamic obstacle appeared), so this trajectory replaces the previous
  // one whatever its risk: the order of decreasing risk starts again here.
  bool replanned = false;
  // Flight time, s (EvaluateTrajectory's: the ground speed in wind). Set by
  // MakePlanner's planners on every improvement they report.
  double flight_time_s = 0.0;
  // With PlanOptions::limits.pareto: the non-dominated (risk, flight time)
  // trajectories found so far that meet the limits, by increasing flight time.
  std::vector<FrontPoint> front;
};

struct TreeEdge {
  Pose from;
  Pose to;  // the parent (towards the goal)
};

struct PlanResult {
  StopReason reason = StopReason::kNoSolution;
  std::optional<PlanImprovement> best;
  int64_t iterations = 0;
  int64_t tree_size = 0;
  double elapsed_s = 0.0;
  uint64_t configurations_evaluated = 0;
  std::vector<TreeEdge> tree;  // only with PlanOptions::record_tree
  // With PlanOptions::limits.pareto: the final front.
  std::vector<FrontPoint> front;
  // With active limits: what the filter saw, and the note saying why there is
  // no trajectory when every one found broke a limit.
  LimitSummary limits;
};

// Called on the planner's thread for every improvement, in order of strictly
// decreasing risk (a `replanned` improvement starts the order again), except
// GENETIC, whose improvements are in order of decreasing fitness (a weighted
// sum of length and sampled risk: its risk may rise where the length falls
// more; docs/planners.md). Must not block for long: the planner waits for it.
using ImprovementCallback = std::function<void(const PlanImprovement&)>;

class Planner {
 public:
  virtual ~Planner() = default;

  // Plans. Errors (InvalidArgument) only for a bad problem or options: start or
  // goal not admissible (the message names which, and the violation), unknown
  // or out-of-range parameter, no budget. Having no solution is not an error.
  virtual absl::StatusOr<PlanResult> Plan(const PlanningProblem& problem,
                                          const PlanOptions& options,
                                          const CancellationToken& cancel,
                                          const ImprovementCallback& on_improvement) = 0;
};

// Creates a planner. `evaluator` computes the risk batches (a
// DirectRiskEvaluator when null); it must outlive the planner.
absl::StatusOr<std::unique_ptr<Planner>> MakePlanner(PlannerAlgorithm algorithm,
                                                     RiskEvaluator* evaluator = nullptr);

// Names, defaults and documentation of an algorithm's parameters.
struct PlannerParamInfo {
  std::string name;
  double default_value = 0.0;
  double min_value = 0.0;
  double max_value = 0.0;
  std::string help;
};
const std::vector<PlannerParamInfo>& PlannerParams(PlannerAlgorithm algorithm);

// Checks the start and goal of a problem: finite, and admissible under spec
// section 6. InvalidArgument naming "start" or "goal" and the violation.
absl::Status CheckEndpoints(const PlanningProblem& problem);

// The check of one pose that CheckEndpoints makes: finite, and admissible
// under spec section 6. InvalidArgument naming `which` ("start", "goal") and
// the violation.
absl::Status CheckEndpoint(const RiskModel& model, const Pose& pose, const char* which);

// Checks the request-carried obstacles of `options` for `algorithm`: finite
// coordinates, x0_m < x1_m and y0_m < y1_m, at_iteration >= 0, at most
// kMaxObstaclePoints points and kMaxDynamicObstacles areas, and support:
// RRT, GENETIC and HARMONIC take obstacle points, HARMONIC alone takes
// dynamic obstacles, RISK_RRT_STAR takes neither. InvalidArgument naming the
// field and its index. Every planner's Plan() calls it before planning (so
// RISK_RRT_STAR refuses a request that carries obstacles rather than ignoring
// them); callers may call it earlier to fail before any work.
absl::Status CheckRequestObstacles(PlannerAlgorithm algorithm, const PlanOptions& options);

// The longest piece a planner can fly on `map` and the samples it needs, an
// upper bound computed from the request alone. Every pose a planner flies
// through lies on the map (x, y) and between the lowest terrain and the
// highest ceiling (terrain + max_agl_m), or at an altitude the request names
// (start, goal, the planner parameters flight_altitude_m and
// fixed_altitude_m). Between two such poses the planar Dubins path is at
// most D + (2 + 4 pi) R (D the map's diagonal: an LSL path always exists),
// and a climb of dz flies at most |dz| / tan(max_climb_rad) + 2 pi R
// horizontally (spec section 5), so a piece is at most
// hypot(max(D + (2 + 4 pi) R, dz_max / tan(max_climb_rad) + 2 pi R), dz_max)
// long. Its samples: PartCount of that at the finest step the planner uses
// (sample_step_m, or GENETIC's risk_step_m if finer), plus its two ends.
struct EdgeSampleBound {
  double map_diagonal_m = 0.0;
  double climb_m = 0.0;   // dz_max
  double length_m = 0.0;  // the longest piece
  double step_m = 0.0;    // the finest sampling step
  int64_t samples = 0;    // saturating (PartCount)
};
EdgeSampleBound ProjectEdgeSamples(PlannerAlgorithm algorithm, const RiskMap& map,
                                   const ModelParams& params, const Pose& start, const Pose& goal,
                                   const std::map<std::string, double>& planner_params);

// InvalidArgument when ProjectEdgeSamples exceeds `max_edge_samples`,
// naming the parameters that make the edges long or finely sampled, the
// projected samples and the limit (and `limit_source`, e.g. a server flag,
// when not empty).
absl::Status CheckEdgeSampleBound(PlannerAlgorithm algorithm, const RiskMap& map,
                                  const ModelParams& params, const Pose& start, const Pose& goal,
                                  const std::map<std::string, double>& planner_params,
                                  int64_t max_edge_samples, std::string_view limit_source = "");

// CheckEdgeSampleBound for a problem and options.max_edge_samples. Every
// planner's Plan() calls it before planning, so no loop over an edge's
// samples can run longer than that.
absl::Status CheckEdgeSamples(PlannerAlgorithm algorithm, const PlanningProblem& problem,
                              const PlanOptions& options);

}  // namespace riskplan

#endif  // RISKPLAN_CORE_PLANNERS_PLANNER_H_
