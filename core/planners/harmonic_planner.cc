#include "core/planners/harmonic_planner.h"

#include <algorithm>
#include <cmath>

#include "core/base/geometry.h"
#include "core/planners/harmonic_potential.h"
#include "core/planners/obstacle_points.h"
#include "core/planners/path_realizer.h"
#include "core/planners/planner_support.h"

namespace riskplan {
namespace {

// The finest tolerance the relaxation is pushed to when a descent stalls:
// below it a sweep's changes are rounding noise.
constexpr double kFinestTolerance = 1e-15;
constexpr int kAutoMaxSide = 512;

class Run : private SeedRunBase {
 public:
  Run(const PlanningProblem& problem, const PlanOptions& options, const PlannerParamValues& params,
      RiskEvaluator* evaluator, const CancellationToken& cancel,
      const ImprovementCallback& on_improvement)
      : SeedRunBase(problem, options, evaluator, cancel, on_improvement),
        tolerance_(params.Get("tolerance")),
        clearance_m_(params.Get("clearance_m")),
        flight_altitude_m_(params.Get("flight_altitude_m")),
        factor_(Factor(model_.map(), static_cast<int>(params.Get("cell_factor")))),
        cell_m_(factor_ * model_.map().res()),
        nx_((model_.map().nx() + factor_ - 1) / factor_),
        ny_((model_.map().ny() + factor_ - 1) / factor_),
        omega_(params.Get("omega") > 0.0 ? params.Get("omega")
                                         : HarmonicPotential::OptimalOmega(nx_, ny_)),
        potential_(nx_, ny_),
        request_points_(options.obstacle_points,
                        std::max({2.0 * clearance_m_, 4.0 * model_.map().res(), 1.0})),
        checker_(model_, &request_points_, clearance_m_) {}

  absl::StatusOr<PlanResult> Execute();

 private:
  static int Factor(const RiskMap& map, int requested) {
    if (requested > 0) return requested;
    const int side = std::max(map.nx(), map.ny());
    return std::max(1, (side + kAutoMaxSide - 1) / kAutoMaxSide);
  }
  GridCell CellOf(double x, double y) const {
    const RiskMap& map = model_.map();
    return {ClampedCell(x - map.x0(), cell_m_, nx_), ClampedCell(y - map.y0(), cell_m_, ny_)};
  }
  bool Pinned(int i, int j) const {
    return GridCell{i, j} == start_cell_ || GridCell{i, j} == goal_cell_;
  }
  void Block(int i, int j) {
    if (!Pinned(i, j)) potential_.SetObstacle(i, j);
  }
  void BuildGrid();
  // Applies the dynamic obstacles due at the current sweep. True if any.
  bool ApplyDueObstacles();
  // Realizes, evaluates and streams a descent.
  absl::Status Report(const std::vector<GridCell>& cells);

  const double tolerance_;
  const double clearance_m_;
  const double flight_altitude_m_;
  const int factor_;
  const double cell_m_;
  const int nx_;
  const int ny_;
  const double omega_;
  HarmonicPotential potential_;
  ObstaclePointSet request_points_;
  TrajectoryChecker checker_;
  GridCell start_cell_;
  GridCell goal_cell_;
  std::vector<DynamicObstacle> pending_;  // by at_iteration
  size_t next_pending_ = 0;
  std::vector<ClosedArea> closed_;
  int64_t sweeps_ = 0;
  int64_t env_start_ = 0;  // sweep at which the current obstacles were set
  std::optional<PlanImprovement> best_;
  bool streamed_ = false;     // something was streamed
  bool env_changed_ = false;  // an obstacle appeared since the last stream
  bool reported_in_env_ = false;
};

void Run::BuildGrid() {
  const RiskMap& map = model_.map();
  start_cell_ = CellOf(problem_.start.x, problem_.start.y);
  goal_cell_ = CellOf(problem_.goal.x, problem_.goal.y);
  const std::vector<uint8_t> flyable = FlyableCells(model_, flight_altitude_m_);
  for (int j = 0; j < map.ny(); ++j) {
    for (int i = 0; i < map.nx(); ++i) {
      if (flyable[map.Index(i, j)] == 0) Block(i / factor_, j / factor_);
    }
  }
  // Planning cells that reach past the map's east or north edge.
  if (map.nx() % factor_ != 0) {
    for (int j = 0; j < ny_; ++j) Block(nx_ - 1, j);
  }
  if (map.ny() % factor_ != 0) {
    for (int i = 0; i < nx_; ++i) Block(i, ny_ - 1);
  }
  // Cells that come within the clearance of a request's point.
  for (const Point2& p : options_.obstacle_points) {
    const GridCell lo = CellOf(p.x - clearance_m_, p.y - clearance_m_);
    const GridCell hi = CellOf(p.x + clearance_m_, p.y + clearance_m_);
    for (int j = lo.j; j <= hi.j; ++j) {
      for (int i = lo.i; i <= hi.i; ++i) {
        const double cx0 = map.x0() + i * cell_m_, cy0 = map.y0() + j * cell_m_;
        const double dx = std::max({cx0 - p.x, 0.0, p.x - (cx0 + cell_m_)});
        const double dy = std::max({cy0 - p.y, 0.0, p.y - (cy0 + cell_m_)});
        if (dx * dx + dy * dy <= clearance_m_ * clearance_m_) Block(i, j);
      }
    }
  }
  potential_.SetGoal(goal_cell_.i, goal_cell_.j);
  if (!(start_cell_ == goal_cell_)) potential_.SetFree(start_cell_.i, start_cell_.j);
  pending_ = options_.dynamic_obstacles;
  std::stable_sort(pending_.begin(), pending_.end(),
                   [](const DynamicObstacle& a, const DynamicObstacle& b) {
                     return a.at_iteration < b.at_iteration;
                   });
}

bool Run::ApplyDueObstacles() {
  bool any = false;
  const RiskMap& map = model_.map();
  while (next_pending_ < pending_.size() && pending_[next_pending_].at_iteration <= sweeps_) {
    const DynamicObstacle& d = pending_[next_pending_++];
    closed_.push_back({d.x0_m, d.y0_m, d.x1_m, d.y1_m});
    // Planning cells overlapping [x0, x1) x [y0, y1). An area may lie far
    // outside the map (any finite coordinates are valid), so cell numbers are
    // clamped to just outside the grid before they become ints.
    const auto cell = [](double c, int n) {
      return static_cast<int>(std::clamp(c, -1.0, static_cast<double>(n)));
    };
    const int i0 = cell(std::floor((d.x0_m - map.x0()) / cell_m_), nx_);
    const int j0 = cell(std::floor((d.y0_m - map.y0()) / cell_m_), ny_);
    const int i1 = cell(std::ceil((d.x1_m - map.x0()) / cell_m_), nx_) - 1;
    const int j1 = cell(std::ceil((d.y1_m - map.y0()) / cell_m_), ny_) - 1;
    for (int j = std::max(j0, 0); j <= std::min(j1, ny_ - 1); ++j) {
      for (int i = std::max(i0, 0); i <= std::min(i1, nx_ - 1); ++i) Block(i, j);
    }
    any = true;
  }
  if (!any) return false;
  checker_.set_closed_areas(closed_);
  if (best_.has_value() && checker_.Violations(best_->waypoints, /*first_only=*/true) > 0) {
    best_.reset();
  }
  if (streamed_) env_changed_ = true;
  reported_in_env_ = false;
  return true;
}

absl::Status Run::Report(const std::vector<GridCell>& cells) {
  const RiskMap& map = model_.map();
  std::vector<Point2> path = {{problem_.start.x, problem_.start.y}};
  for (size_t k = 1; k + 1 < cells.size(); ++k) {
    path.push_back(
        {map.x0() + (cells[k].i + 0.5) * cell_m_, map.y0() + (cells[k].j + 0.5) * cell_m_});
  }
  path.push_back({problem_.goal.x, problem_.goal.y});
  RealizerOptions realizer_options;
  realizer_options.flight_altitude_m = flight_altitude_m_;
  realizer_options.max_deviation_m = std::max(2.0 * cell_m_, model_.params().GroundTurnRadius());
  const PathRealizer realizer(checker_, realizer_options);
  std::optional<std::vector<Pose>> waypoints =
      realizer.Realize(problem_.start, problem_.goal, path);
  reported_in_env_ = true;
  if (!waypoints.has_value()) return absl::OkStatus();
  // The token only: the last descent is reported when the time is up.
  auto improvement =
      EvaluateWaypoints(model_, std::move(*waypoints), evaluator_, limits_.CancelStop());
  if (!improvement.ok()) return improvement.status();
  if (!improvement->has_value()) return absl::OkStatus();
  PlanImprovement& found = **improvement;
  if (best_.has_value()) {
    if (env_changed_ ? found.waypoints.size() == best_->waypoints.size() &&
                           std::equal(found.waypoints.begin(), found.waypoints.end(),
                                      best_->waypoints.begin(),
                                      [](const Pose& a, const Pose& b) {
                                        return a.x == b.x && a.y == b.y && a.z == b.z &&
                                               a.theta == b.theta;
                                      })
                     : !(found.risk < best_->risk)) {
      env_changed_ = false;
      return absl::OkStatus();
    }
  }
  found.iterations = sweeps_;
  found.tree_size = static_cast<int64_t>(nx_) * ny_;
  found.elapsed_s = limits_.Elapsed();
  found.replanned = env_changed_;
  best_ = found;
  streamed_ = true;
  env_changed_ = false;
  if (on_improvement_) on_improvement_(found);
  return absl::OkStatus();
}

absl::StatusOr<PlanResult> Run::Execute() {
  BuildGrid();
  PlanResult result;
  result.reason = StopReason::kBudgetExhausted;
  double tolerance = tolerance_;
  bool settled = false;  // converged (and reported) for the current obstacles
  while (true) {
    if (limits_.Cancelled()) {
      result.reason = StopReason::kCancelled;
      break;
    }
    if (ApplyDueObstacles()) {
      // The relaxation goes on from the current values.
      settled = false;
      tolerance = tolerance_;
      env_start_ = sweeps_;
    }
    if (settled) {
      // Converged: sweeps would change nothing until the next obstacle.
      const int64_t budget = limits_.max_iterations();
      if (next_pending_ < pending_.size() &&
          (budget == 0 || pending_[next_pending_].at_iteration < budget)) {
        sweeps_ = std::max(sweeps_, pending_[next_pending_].at_iteration);
        continue;
      }
      result.reason = StopReason::kConverged;
      break;
    }
    if (limits_.OutOfIterations(sweeps_) || limits_.OutOfTime()) {
      if (!reported_in_env_) {
        if (auto cells = potential_.Descend(start_cell_); cells.has_value()) {
          if (absl::Status s = Report(*cells); !s.ok() && !IsRunStopped(s)) return s;
        }
      }
      break;
    }
    // SOR first; Gauss-Seidel once SOR has had its share (see
    // harmonic_potential.h: over-relaxation stalls on steeply decaying values).
    const bool sor = sweeps_ - env_start_ < 2 * (static_cast<int64_t>(nx_) + ny_);
    const bool converged = potential_.Sweep(sor ? omega_ : 1.0, tolerance);
    ++sweeps_;
    if (!converged) continue;
    std::optional<std::vector<GridCell>> cells = potential_.Descend(start_cell_);
    if (cells.has_value()) {
      if (absl::Status s = Report(*cells); !s.ok()) {
        if (!IsRunStopped(s)) return s;
        result.reason = StopReason::kCancelled;  // only the token stops a report
        break;
      }
      settled = true;
    } else if (potential_.Value(start_cell_.i, start_cell_.j) == 0.0 ||
               tolerance <= kFinestTolerance) {
      settled = true;  // the goal cannot be reached from the start
    } else {
      tolerance = std::max(tolerance * 0.01, kFinestTolerance);
    }
  }
  if (!best_.has_value() && result.reason != StopReason::kCancelled) {
    result.reason = StopReason::kNoSolution;
  }
  result.best = best_;
  result.iterations = sweeps_;
  result.tree_size = static_cast<int64_t>(nx_) * ny_;
  result.elapsed_s = limits_.Elapsed();
  result.configurations_evaluated = evaluator_->evaluated();
  return result;
}

const std::vector<PlannerParamInfo>& ParamInfo() {
  static const auto* info = new std::vector<PlannerParamInfo>{
      {"cell_factor", 0, 0, 64,
       "map cells per planning cell along each axis (0: the smallest keeping both sides <= 512)"},
      {"tolerance", 1e-6, 1e-15, 0.1,
       "convergence: no free cell changes by more than this times its value in one sweep"},
      {"omega", 0.0, 0.0, 1.99,
       "over-relaxation factor (0: the optimal one for the grid; 1: Gauss-Seidel)"},
      {"clearance_m", 20.0, 0.0, 1000.0,
       "planning cells within this distance of a request's obstacle point are obstacles, m"},
      {"flight_altitude_m", 0.0, 0.0, 20000.0,
       "plan at this altitude AMSL: cells where it is not admissible are obstacles (0: any "
       "admissible altitude)"},
  };
  return *info;
}

}  // namespace

constinit const AlgorithmEntry kHarmonicEntry = {&ParamInfo,
                                                 &PlanSeedRun<Run, PlannerAlgorithm::kHarmonic>};

}  // namespace riskplan
