// The missions of a Run (core/planners/risk_rrt_star_run.h): their budgets and
// ends, the branch-and-bound limit they share, round-robin picks, and their
// reports and results.
#include <algorithm>
#include <cmath>
#include <utility>

#include "core/base/check.h"
#include "core/flight/trajectory.h"
#include "core/planners/risk_rrt_star_run.h"

namespace riskplan::rrt_star {

Run::Run(const RiskModel& model, const Pose& goal, std::vector<RunMission> missions, uint64_t seed,
         bool record_tree, const Params& params, RiskEvaluator* evaluator,
         const CancellationToken& cancel, RunCallbacks callbacks, const GoalTree* initial_tree)
    : model_(model),
      goal_(goal),
      record_tree_(record_tree),
      params_(params),
      evaluator_(evaluator),
      cancel_(cancel),
      callbacks_(std::move(callbacks)),
      begin_(std::chrono::steady_clock::now()),
      initial_tree_(initial_tree),
      rng_(seed),
      refine_rng_(seed ^ 0x5265666e65526e67ULL),
      refiner_(model_, evaluator, params.refine_scale_m, params.MidpointsPerBatch()),
      grid_(model_.map().x0(), model_.map().y0(), model_.map().width_m(), model_.map().height_m(),
            std::max(50.0, params.near_radius_m / 2.0)) {
  for (RunMission& spec : missions) {
    MissionRun m;
    if (spec.budget.max_time_s > 0.0) {
      m.deadline = begin_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                std::chrono::duration<double>(spec.budget.max_time_s));
    }
    m.spec = std::move(spec);
    missions_.push_back(std::move(m));
  }
  running_ = missions_.size();
  ResetStop();
}

std::unique_ptr<RiskEvaluator> OwnEvaluator(const Params& params) {
  // On demo-city about 40 % of the requests of a run repeat a kernel site, but
  // a table large enough to hold them misses the CPU caches, and measured no
  // faster than recomputing: the cache is off unless asked for.
  if (params.risk_cache_log2 > 0) {
    return std::make_unique<CachingRiskEvaluator>(params.risk_cache_log2);
  }
  return std::make_unique<DirectRiskEvaluator>();
}

double Run::Elapsed() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - begin_).count();
}

void Run::SetLimits(const FlightLimits& limits) {
  RISKPLAN_DCHECK(missions_.size() == 1);
  const bool time_or_length = limits.max_flight_time_s > 0.0 || limits.max_length_m > 0.0;
  const bool quickest_under_risk =
      limits.objective == PlanObjective::kMinTime && limits.max_risk > 0.0;
  limited_ = !limits.pareto && (time_or_length || quickest_under_risk);
  if (!limited_) return;
  limits_ = limits;
  penalise_length_ = limits.max_flight_time_s == 0.0 && limits.max_length_m > 0.0 &&
                     limits.objective == PlanObjective::kMinRisk;
}

bool Run::Fits(const RouteNumbers& r) const {
  if (!std::isfinite(r.risk)) return false;
  // In still air the time of the whole route from its length, as the limit
  // filter and EvaluateTrajectory take it.
  const ModelParams& mp = model_.params();
  const double time = mp.Calm() ? FlightTimeS(r.length_m, mp.airspeed_mps) : r.time_s;
  return CheckNumbers(r.risk, r.length_m, time, limits_).meets;
}

bool Run::RankBelow(const RouteNumbers& a, const RouteNumbers& b) const {
  const bool fa = Fits(a);
  const bool fb = Fits(b);
  if (fa != fb) return fa;
  if (!std::isfinite(a.risk)) return false;
  if (!std::isfinite(b.risk)) return true;
  if (!fa) {
    const double ca = penalise_length_ ? a.length_m : a.time_s;
    const double cb = penalise_length_ ? b.length_m : b.time_s;
    return a.risk + lambda_ * ca < b.risk + lambda_ * cb;
  }
  if (limits_.objective == PlanObjective::kMinTime) {
    if (a.time_s != b.time_s) return a.time_s < b.time_s;
    return a.risk < b.risk;
  }
  if (a.risk != b.risk) return a.risk < b.risk;
  return a.time_s < b.time_s;
}

Run::RouteNumbers Run::StartRoute(size_t m) const {
  const Node& n = nodes_[StartNode(m)];
  if (n.parent < 0) return RouteNumbers{};
  return RouteNumbers{n.cost, n.to_goal_s, n.to_goal_m};
}

namespace {
// How far lambda moves after one connection of the start: by
// exp(kLambdaGain * relative violation), at most by a factor of
// exp(kLambdaStep) either way (docs/planners.md, "Limits").
constexpr double kLambdaGain = 4.0;
constexpr double kLambdaStep = 0.7;
// lambda stays within this factor of its first value either way. Measured on
// the README's demo with a 600-s endurance (docs/benchmarks.md): 1e3 let
// lambda swing the tree between the quick and the safe routes; 30 kept four
// seeds of five within 2 % of the best.
constexpr double kLambdaRange = 30.0;
}  // namespace

void Run::AdaptLambda(const RouteNumbers& key_best) {
  if (!std::isfinite(key_best.risk)) return;
  const ModelParams& mp = model_.params();
  const double time = mp.Calm() ? FlightTimeS(key_best.length_m, mp.airspeed_mps) : key_best.time_s;
  // The relative excess over the time and length limits (> 0: broken).
  double excess = -kInf;
  if (limits_.max_flight_time_s > 0.0) {
    excess = std::max(excess, time / limits_.max_flight_time_s - 1.0);
  }
  if (limits_.max_length_m > 0.0) {
    excess = std::max(excess, key_best.length_m / limits_.max_length_m - 1.0);
  }
  // > 0: more weight on C.
  double push = excess;
  if (limits_.objective == PlanObjective::kMinTime && !(excess > 0.0)) {
    // The quickest route: under a risk limit more weight on time while the
    // route has slack under it, less once it breaks it; without one, more
    // weight on time (nothing to trade it against).
    push = limits_.max_risk > 0.0 ? 1.0 - key_best.risk / limits_.max_risk : 1.0;
  }
  if (!std::isfinite(push)) return;
  const double c = penalise_length_ ? key_best.length_m : key_best.time_s;
  if (lambda_ == 0.0) {
    // The first push up: the route's own risk per unit of C, so that both
    // terms weigh alike; lambda then stays within kLambdaRange of it either
    // way (the slope of a risk-time front is of that order).
    if (push > 0.0 && c > 0.0) {
      lambda_ = std::max(key_best.risk, 1e-300) / c;
      lambda_ref_ = lambda_;
    }
    return;
  }
  lambda_ *= std::exp(std::clamp(kLambdaGain * push, -kLambdaStep, kLambdaStep));
  lambda_ = std::clamp(lambda_, lambda_ref_ / kLambdaRange, lambda_ref_ * kLambdaRange);
}

void Run::PieceTimeLength(const Pose& from, const Pose& to, double* time_s,
                          double* length_m) const {
  const ModelParams& mp = model_.params();
  const TrajectoryPiece piece =
      TrajectoryPiece::Manoeuvre(from, to, mp.GroundTurnRadius(), mp.GroundClimbAngle());
  *length_m = piece.Length();
  if (mp.Calm()) {
    *time_s = *length_m / mp.airspeed_mps;
    return;
  }
  // In wind PieceRisk's sum of ds / gs over the midpoints, without risks.
  PieceRisk rule(piece, mp.sample_step_m, mp);
  const ConfigurationRisk none;
  for (int64_t k = 0; k < rule.parts(); ++k) rule.Add(none, rule.Midpoint(k));
  *time_s = rule.FlightTimeS();
}

double Run::Bound() const {
  if (limited_) {
    // Branch and bound on Key: a route that would improve on the start's
    // fitting route has R + lambda * C below its R + lambda * (the limit on
    // C) (MIN_RISK), or below the risk limit + lambda * its time (MIN_TIME).
    // Without a fitting route nothing is refused.
    const RouteNumbers start = StartRoute(0);
    if (!Running(0) || !Fits(start)) return kInf;
    if (limits_.objective == PlanObjective::kMinTime) {
      if (limits_.max_risk > 0.0) return limits_.max_risk + lambda_ * start.time_s;
      return kInf;
    }
    const double c_limit = penalise_length_ ? limits_.max_length_m
                           : limits_.max_flight_time_s > 0.0 ? limits_.max_flight_time_s
                                                               : kInf;
    return start.risk + lambda_ * c_limit;
  }
  double bound = -kInf;
  for (size_t m = 0; m < missions_.size(); ++m) {
    if (Running(m)) bound = std::max(bound, nodes_[StartNode(m)].cost);
  }
  return bound;
}

std::optional<std::chrono::steady_clock::time_point> Run::EarliestDeadline() const {
  std::optional<std::chrono::steady_clock::time_point> earliest;
  for (const MissionRun& m : missions_) {
    if (m.state != MissionState::kRunning || !m.deadline.has_value()) continue;
    if (!earliest.has_value() || *m.deadline < *earliest) earliest = m.deadline;
  }
  return earliest;
}

void Run::ResetStop() {
  // Only the earliest deadline matters: when it passes, UpdateMissions ends
  // that mission and the condition moves on to the next one.
  stop_ = StopCondition(&cancel_, nullptr, EarliestDeadline());
  refiner_.set_stop(stop_);
}

bool Run::UpdateMissions() {
  if (running_ == 0) return false;
  if (cancel_.IsCancelled()) {
    for (size_t m = 0; m < missions_.size(); ++m) {
      if (Running(m)) Finish(m, StopReason::kCancelled);
    }
    return false;
  }
  const bool full = static_cast<int64_t>(nodes_.size()) >= params_.max_nodes;
  const auto now = std::chrono::steady_clock::now();
  bool ended = false;
  for (size_t m = 0; m < missions_.size(); ++m) {
    if (!Running(m)) continue;
    const MissionRun& r = missions_[m];
    const bool out_of_iterations =
        r.spec.budget.max_iterations > 0 && iterations_ >= r.spec.budget.max_iterations;
    const bool out_of_time = r.deadline.has_value() && now >= *r.deadline;
    if (full || out_of_iterations || out_of_time) {
      Finish(m, StopReason::kBudgetExhausted);
      ended = true;
    } else if (r.best.has_value() && r.best->risk <= 0.0) {
      Finish(m, StopReason::kConverged);  // nothing is cheaper than 0
      ended = true;
    }
  }
  if (ended) ResetStop();
  return running_ > 0;
}

void Run::Finish(size_t m, StopReason reason) {
  MissionRun& r = missions_[m];
  r.state = MissionState::kDone;
  --running_;
  // Its start no longer needs the samples only it could use.
  UpdateInformedLimit();
  PlanResult result;
  result.reason = reason;
  if (!r.best.has_value() && reason != StopReason::kCancelled) {
    result.reason = StopReason::kNoSolution;
  }
  result.best = std::move(r.best);
  r.best.reset();
  r.best_pieces.clear();
  result.iterations = iterations_;
  result.tree_size = static_cast<int64_t>(nodes_.size());
  result.elapsed_s = Elapsed();
  result.configurations_evaluated = evaluator_->evaluated();
  // The tree once, as it stands at the end: one copy per mission could take
  // hundreds of times a tree's memory.
  if (record_tree_ && running_ == 0) {
    for (size_t n = 0; n < nodes_.size(); ++n) {
      if (nodes_[n].parent >= 0)
        result.tree.push_back({nodes_[n].pose, nodes_[nodes_[n].parent].pose});
    }
  }
  if (callbacks_.on_result) callbacks_.on_result(m, std::move(result));
}

void Run::FailRunning(const absl::Status& status) {
  failed_ = true;
  for (size_t m = 0; m < missions_.size(); ++m) {
    if (!Running(m)) continue;
    missions_[m].state = MissionState::kDone;
    --running_;
    if (callbacks_.on_result) callbacks_.on_result(m, status);
  }
}

int Run::NextMission(size_t* cursor, Pick pick) const {
  const size_t n = missions_.size();
  for (size_t k = 0; k < n; ++k) {
    const size_t m = (*cursor + k) % n;
    if (!Running(m)) continue;
    if (pick == Pick::kWithBest && !missions_[m].best.has_value()) continue;
    if (pick == Pick::kWithCost && !std::isfinite(nodes_[StartNode(m)].cost)) continue;
    *cursor = (m + 1) % n;
    return static_cast<int>(m);
  }
  return -1;
}

void Run::MaybeReport() {
  for (size_t m = 0; m < missions_.size(); ++m) {
    if (Running(m)) MaybeReportMission(m);
  }
}

void Run::MaybeReportMission(size_t m) {
  MissionRun& r = missions_[m];
  const int32_t start = StartNode(m);
  if (!std::isfinite(nodes_[start].cost)) return;
  if (!limited_ && r.best.has_value() && !(nodes_[start].cost < r.best->risk)) return;
  if (limited_ && r.best.has_value() && r.best_fits) {
    // Only a fitting route that improves the objective can be reported.
    // (The tree's sums are a guide; the exact numbers below decide.)
    if (!Fits(StartRoute(m))) return;
  }
  std::vector<Pose> waypoints;
  // The trajectory's risk as EvaluateTrajectory computes it: the sum of its
  // piece risks from start to goal. Each edge risk was computed exactly as
  // that piece's risk (same manoeuvre, same samples, same formula), so the
  // total is bit for bit what an independent evaluation gives; the tree's
  // R(start) may differ from it in the last bits (other order of additions).
  double risk = 0.0;
  double length = 0.0;
  const ModelParams& mp = model_.params();
  for (int32_t n = start; n >= 0; n = nodes_[n].parent) {
    waypoints.push_back(nodes_[n].pose);
    if (nodes_[n].parent >= 0) risk += nodes_[n].edge_risk;
  }
  if (!limited_ && r.best.has_value() && !(risk < r.best->risk)) return;
  // The length of each piece, start to goal, as EvaluateTrajectory's pieces
  // give it (the same manoeuvre between the same poses), made once per edge.
  for (int32_t n = start; nodes_[n].parent >= 0; n = nodes_[n].parent) {
    Node& node = nodes_[n];
    if (node.length_parent != node.parent) {
      node.edge_length = TrajectoryPiece::Manoeuvre(node.pose, nodes_[node.parent].pose,
                                                    mp.GroundTurnRadius(), mp.GroundClimbAngle())
                             .Length();
      node.length_parent = node.parent;
    }
    length += node.edge_length;
  }
  bool fits = false;
  double time_s = 0.0;
  if (limited_) {
    // The route's exact numbers: its risk and length as EvaluateTrajectory
    // sums them, and its flight time from the length in still air, else the
    // sum of the edges' times from start to goal (EvaluateTrajectory's order).
    if (mp.Calm()) {
      time_s = FlightTimeS(length, mp.airspeed_mps);
    } else {
      for (int32_t n = start; nodes_[n].parent >= 0; n = nodes_[n].parent) {
        time_s += nodes_[n].edge_s;
      }
    }
    fits = CheckNumbers(risk, length, time_s, limits_).meets;
    if (r.best.has_value()) {
      if (r.best_fits) {
        // A fitting route that improves the objective.
        if (!fits) return;
        const bool better = limits_.objective == PlanObjective::kMinTime
                                ? time_s < r.best_time_s ||
                                      (time_s == r.best_time_s && risk < r.best->risk)
                                : risk < r.best->risk;
        if (!better) return;
      } else if (!fits && !(time_s < r.best_time_s) && !(risk < r.best->risk)) {
        // Before any fits: a route quicker or safer than those reported
        // (the filter's note gives the best values found).
        return;
      }
    }
    r.best_fits = fits;
    r.best_time_s = time_s;
  }
  r.best_pieces.clear();
  PlanImprovement improvement;
  improvement.waypoints = std::move(waypoints);
  improvement.risk = risk;
  improvement.length_m = length;
  improvement.iterations = iterations_;
  improvement.tree_size = static_cast<int64_t>(nodes_.size());
  improvement.elapsed_s = Elapsed();
  r.best = improvement;
  if (callbacks_.on_improvement) callbacks_.on_improvement(m, improvement);
}

void Run::TracePath(size_t m) {
  path_nodes_.clear();
  path_poses_.clear();
  path_risks_.clear();
  path_s_.clear();
  path_m_.clear();
  for (int32_t n = StartNode(m); n >= 0; n = nodes_[n].parent) {
    path_nodes_.push_back(n);
    path_poses_.push_back(nodes_[n].pose);
    if (nodes_[n].parent >= 0) {
      path_risks_.push_back(nodes_[n].edge_risk);
      if (limited_) {
        path_s_.push_back(nodes_[n].edge_s);
        path_m_.push_back(nodes_[n].edge_m);
      }
    }
  }
}

}  // namespace riskplan::rrt_star
