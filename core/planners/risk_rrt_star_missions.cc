// The missions of a Run (core/planners/risk_rrt_star_run.h): their budgets and
// ends, the branch-and-bound limit they share, round-robin picks, and their
// reports and results.
#include <algorithm>
#include <cmath>
#include <utility>

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

double Run::Bound() const {
  double bound = -kInf;
  for (size_t m = 0; m < missions_.size(); ++m) {
    if (Running(m)) bound = std::max(bound, nodes_[StartNode(m)].cost);
  }
  return bound;
}

void Run::ResetStop() {
  // Only the earliest deadline matters: when it passes, UpdateMissions ends
  // that mission and the condition moves on to the next one.
  std::optional<std::chrono::steady_clock::time_point> earliest;
  for (const MissionRun& m : missions_) {
    if (m.state != MissionState::kRunning || !m.deadline.has_value()) continue;
    if (!earliest.has_value() || *m.deadline < *earliest) earliest = m.deadline;
  }
  stop_ = StopCondition(&cancel_, nullptr, earliest);
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
  if (r.best.has_value() && !(nodes_[start].cost < r.best->risk)) return;
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
  if (r.best.has_value() && !(risk < r.best->risk)) return;
  r.best_pieces.clear();
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
  for (int32_t n = StartNode(m); n >= 0; n = nodes_[n].parent) {
    path_nodes_.push_back(n);
    path_poses_.push_back(nodes_[n].pose);
    if (nodes_[n].parent >= 0) path_risks_.push_back(nodes_[n].edge_risk);
  }
}

}  // namespace riskplan::rrt_star
