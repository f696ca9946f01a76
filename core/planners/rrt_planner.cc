#include "core/planners/rrt_planner.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/base/random.h"
#include "core/planners/obstacle_points.h"
#include "core/planners/path_realizer.h"
#include "core/planners/planner_support.h"
#include "core/planners/spatial_grid.h"

namespace riskplan {
namespace {

struct Vertex {
  Point2 p;
  int32_t parent = -1;
};

double Distance(const Point2& a, const Point2& b) { return std::hypot(b.x - a.x, b.y - a.y); }

// Distance from p to the nearest of `points` (infinity when there is none).
double NearestDistance(const Point2& p, const std::vector<Point2>& points) {
  double best = std::numeric_limits<double>::infinity();
  for (const Point2& q : points) best = std::min(best, Distance(p, q));
  return best;
}

class Run : private SeedRunBase {
 public:
  Run(const PlanningProblem& problem, const PlanOptions& options, const PlannerParamValues& params,
      RiskEvaluator* evaluator, const CancellationToken& cancel,
      const ImprovementCallback& on_improvement)
      : SeedRunBase(problem, options, evaluator, cancel, on_improvement),
        step_m_(params.Get("step_m")),
        clearance_m_(params.Get("clearance_m")),
        goal_bias_(params.Get("goal_bias")),
        keep_growing_(params.Get("keep_growing") != 0.0),
        flight_altitude_m_(params.Get("flight_altitude_m")),
        max_nodes_(static_cast<size_t>(params.Get("max_nodes"))),
        rng_(options.seed),
        grid_(model_.map().x0(), model_.map().y0(), model_.map().width_m(), model_.map().height_m(),
              std::max(step_m_, 4.0 * model_.map().res())) {}

  absl::StatusOr<PlanResult> Execute();

 private:
  bool EdgeClear(const Point2& a, const Point2& b, double map_clearance_m) const {
    return map_points_.SegmentClear(a, b, map_clearance_m) &&
           request_points_.SegmentClear(a, b, clearance_m_);
  }
  // Tries to fly the branch from the start to `vertex`, then to the goal.
  absl::Status TryConnection(int32_t vertex, bool* reported);

  const double step_m_;
  const double clearance_m_;
  const double goal_bias_;
  const bool keep_growing_;
  const double flight_altitude_m_;
  const size_t max_nodes_;
  Rng rng_;
  SpatialGrid grid_;
  ObstaclePointSet map_points_;
  ObstaclePointSet request_points_;
  std::vector<Vertex> tree_;
  int64_t iterations_ = 0;
  std::optional<PlanImprovement> best_;
  std::optional<TrajectoryChecker> checker_;
  std::optional<PathRealizer> realizer_;
  double start_map_clearance_m_ = 0.0;
  double goal_map_clearance_m_ = 0.0;
};

absl::Status Run::TryConnection(int32_t vertex, bool* reported) {
  *reported = false;
  std::vector<Point2> branch;
  for (int32_t v = vertex; v >= 0; v = tree_[v].parent) branch.push_back(tree_[v].p);
  std::reverse(branch.begin(), branch.end());
  branch.push_back({problem_.goal.x, problem_.goal.y});
  std::optional<std::vector<Pose>> waypoints =
      realizer_->Realize(problem_.start, problem_.goal, branch);
  if (!waypoints.has_value()) return absl::OkStatus();
  auto improvement = EvaluateWaypoints(model_, std::move(*waypoints), evaluator_, limits_.Stop());
  if (!improvement.ok()) return improvement.status();
  if (!improvement->has_value()) return absl::OkStatus();  // the realizer's check passed it
  PlanImprovement& found = **improvement;
  if (best_.has_value() && !(found.risk < best_->risk)) return absl::OkStatus();
  found.iterations = iterations_;
  found.tree_size = static_cast<int64_t>(tree_.size());
  found.elapsed_s = limits_.Elapsed();
  best_ = found;
  *reported = true;
  if (on_improvement_) on_improvement_(found);
  return absl::OkStatus();
}

absl::StatusOr<PlanResult> Run::Execute() {
  const RiskMap& map = model_.map();
  const std::vector<Point2> from_map =
      MapObstaclePoints(map, FlyableCells(model_, flight_altitude_m_));
  const double bucket_m = std::max({2.0 * clearance_m_, 4.0 * map.res(), 1.0});
  map_points_ = ObstaclePointSet(from_map, bucket_m);
  request_points_ = ObstaclePointSet(options_.obstacle_points, bucket_m);
  const Point2 start{problem_.start.x, problem_.start.y};
  const Point2 goal{problem_.goal.x, problem_.goal.y};
  start_map_clearance_m_ = std::min(clearance_m_, 0.99 * NearestDistance(start, from_map));
  goal_map_clearance_m_ = std::min(clearance_m_, 0.99 * NearestDistance(goal, from_map));
  checker_.emplace(model_, &request_points_, clearance_m_);
  RealizerOptions realizer_options;
  realizer_options.flight_altitude_m = flight_altitude_m_;
  realizer_.emplace(*checker_, realizer_options);

  tree_.push_back({start, -1});
  grid_.Insert(0, start.x, start.y);
  PlanResult result;
  result.reason = StopReason::kBudgetExhausted;
  // Set when the budget or the token stopped a connection's evaluation.
  bool stopped = false;
  // The start itself may connect.
  if (Distance(start, goal) <= step_m_ &&
      EdgeClear(start, goal, std::min(start_map_clearance_m_, goal_map_clearance_m_))) {
    bool reported = false;
    if (absl::Status s = TryConnection(0, &reported); !s.ok()) {
      if (!IsRunStopped(s)) return s;
      stopped = true;
    }
    if (reported && !keep_growing_) result.reason = StopReason::kConverged;
  }
  while (!stopped && result.reason != StopReason::kConverged) {
    if (limits_.Cancelled()) {
      result.reason = StopReason::kCancelled;
      break;
    }
    if (limits_.OutOfIterations(iterations_) || limits_.OutOfTime() || tree_.size() >= max_nodes_) {
      break;
    }
    ++iterations_;
    Point2 target = goal;
    if (!(rng_.Uniform() < goal_bias_)) {
      target = {map.x0() + rng_.Uniform() * map.width_m(),
                map.y0() + rng_.Uniform() * map.height_m()};
    }
    const auto nearest = grid_.Nearest(target.x, target.y, 1);
    const int32_t near = nearest.front().second;
    const Point2 from = tree_[near].p;
    const double d = Distance(from, target);
    Point2 to = target;
    if (d >= step_m_) {
      to = {from.x + step_m_ * (target.x - from.x) / d, from.y + step_m_ * (target.y - from.y) / d};
    } else if (!keep_growing_ || d == 0.0 || (target.x == goal.x && target.y == goal.y)) {
      // Seed 004 draws again. (Growing on, the tree takes the point itself,
      // or it would stop growing once its vertices cover the map.)
      continue;
    }
    if (!EdgeClear(from, to, near == 0 ? start_map_clearance_m_ : clearance_m_)) continue;
    const int32_t id = static_cast<int32_t>(tree_.size());
    tree_.push_back({to, near});
    grid_.Insert(id, to.x, to.y);
    if (Distance(to, goal) <= step_m_ && EdgeClear(to, goal, goal_map_clearance_m_)) {
      bool reported = false;
      if (absl::Status s = TryConnection(id, &reported); !s.ok()) {
        if (!IsRunStopped(s)) return s;
        stopped = true;
      }
      if (reported && !keep_growing_) result.reason = StopReason::kConverged;
    }
  }
  if (stopped && limits_.Cancelled()) result.reason = StopReason::kCancelled;
  if (!best_.has_value() && result.reason != StopReason::kCancelled) {
    result.reason = StopReason::kNoSolution;
  }
  result.best = best_;
  result.iterations = iterations_;
  result.tree_size = static_cast<int64_t>(tree_.size());
  result.elapsed_s = limits_.Elapsed();
  result.configurations_evaluated = evaluator_->evaluated();
  if (options_.record_tree) {
    const double z = flight_altitude_m_ > 0.0 ? flight_altitude_m_ : problem_.start.z;
    for (const Vertex& v : tree_) {
      if (v.parent < 0) continue;
      const Point2& p = tree_[v.parent].p;
      const double heading = NormalizeHeading(std::atan2(v.p.y - p.y, v.p.x - p.x));
      result.tree.push_back({Pose{v.p.x, v.p.y, z, heading}, Pose{p.x, p.y, z, heading}});
    }
  }
  return result;
}

const std::vector<PlannerParamInfo>& ParamInfo() {
  static const auto* info = new std::vector<PlannerParamInfo>{
      {"step_m", 100.0, 1.0, 5000.0, "length of every new edge (delta), m"},
      {"clearance_m", 20.0, 0.0, 1000.0,
       "clearance radius (xi): every obstacle point must lie farther than this from an edge, m"},
      {"goal_bias", 0.05, 0.0, 1.0, "share of the drawn points that are the goal"},
      {"keep_growing", 0.0, 0.0, 1.0,
       "0: stop at the first connection (seed 004); 1: keep growing and stream every connection "
       "of lower risk until the budget ends"},
      {"flight_altitude_m", 0.0, 0.0, 20000.0,
       "plan at this altitude AMSL: cells where it is not admissible are obstacles (0: any "
       "admissible altitude; the trajectory follows the middle of the band)"},
      {"max_nodes", 200000, 10, 300000, "largest tree; the run ends when it is reached"},
  };
  return *info;
}

}  // namespace

constinit const AlgorithmEntry kRrtEntry = {&ParamInfo, &PlanSeedRun<Run, PlannerAlgorithm::kRrt>};

}  // namespace riskplan
