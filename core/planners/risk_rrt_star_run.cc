#include "core/planners/risk_rrt_star_run.h"

#include <algorithm>
#include <cmath>

#include "core/flight/dubins.h"
#include "core/planners/risk_guide.h"

namespace riskplan::rrt_star {

bool Run::SampleUniform(Pose* q) {
  const RiskMap& map = model_.map();
  // A few tries: most of a city map is flyable; a miss just ends the iteration.
  for (int attempt = 0; attempt < 16; ++attempt) {
    const double x = map.x0() + rng_.Uniform() * map.width_m();
    const double y = map.y0() + rng_.Uniform() * map.height_m();
    const double theta = rng_.Uniform() * kTwoPi;
    const double u = rng_.Uniform();
    int i = 0;
    int j = 0;
    if (!map.CellOf(x, y, &i, &j) || map.nofly(i, j)) continue;
    const double low = model_.SafeAltitude(i, j);
    const double high = map.terrain(i, j) + model_.params().max_agl_m;
    if (!(low <= high)) continue;
    *q = Pose{x, y, low + u * (high - low), theta};
    return true;
  }
  return false;
}

bool Run::SamplePathBiased(Pose* q) {
  const double length = best_->length_m;
  double s = rng_.Uniform() * length;
  Pose base = best_pieces_.back().End();
  for (const TrajectoryPiece& piece : best_pieces_) {
    if (s <= piece.Length()) {
      base = piece.PoseAt(s);
      break;
    }
    s -= piece.Length();
  }
  const double spread = params_.step_m;
  *q = Pose{base.x + spread * rng_.Normal(), base.y + spread * rng_.Normal(),
            base.z + 20.0 * rng_.Normal(), NormalizeHeading(base.theta + 0.5 * rng_.Normal())};
  return Admissible(*q);
}

Pose Run::Sample(bool* is_start) {
  *is_start = false;
  const double u = rng_.Uniform();
  if (u < params_.goal_bias) {
    *is_start = true;
    return problem_.start;
  }
  Pose q;
  if (best_.has_value() && u < params_.goal_bias + params_.path_bias && SamplePathBiased(&q)) {
    return q;
  }
  if (SampleUniform(&q)) return q;
  *is_start = true;  // a map with almost nothing flyable: head for the start
  return problem_.start;
}

absl::Status Run::ConnectStart() {
  const Pose& start = problem_.start;
  int32_t parent = -1;
  double edge_risk = kInf;
  if (absl::Status s = BestParent(start, KNearestFrom(start, NearCandidates(start), BestCost()),
                                  BestCost(), &parent, &edge_risk);
      !s.ok()) {
    return s;
  }
  if (parent >= 0) SetParent(kStart, parent, edge_risk);
  return absl::OkStatus();
}

absl::Status Run::Extend(const Pose& q_new) {
  const ModelParams& mp = model_.params();
  const std::vector<int32_t> near = NearCandidates(q_new);

  // Parent: the k nearest by Dubins length q_new -> n, best by accumulated
  // risk; branch and bound: a node at or above the best solution is useless.
  int32_t parent = -1;
  double edge_risk = kInf;
  if (absl::Status s =
          BestParent(q_new, KNearestFrom(q_new, near, BestCost()), BestCost(), &parent, &edge_risk);
      !s.ok()) {
    return s;
  }
  if (parent < 0) return absl::OkStatus();
  const double cost = nodes_[parent].cost + edge_risk;

  const int32_t id = static_cast<int32_t>(nodes_.size());
  nodes_.push_back(Node{q_new, -1, kInf, kInf, {}});
  SetParent(id, parent, edge_risk);
  grid_.Insert(id, q_new.x, q_new.y);

  // Rewire: neighbours (the start included) that get cheaper through q_new.
  std::vector<std::pair<double, int32_t>> ranked;
  for (int32_t n : near) {
    if (n == kGoal || n == parent || !(cost < nodes_[n].cost)) continue;
    const double length =
        DubinsAirplanePath(nodes_[n].pose, q_new, mp.turn_radius_m, mp.max_climb_rad).Length();
    ranked.push_back({length, n});
  }
  std::sort(ranked.begin(), ranked.end());
  if (ranked.size() > static_cast<size_t>(params_.k_near)) ranked.resize(params_.k_near);
  std::vector<CandidateEdge> edges;
  for (const auto& [length, n] : ranked) {
    AddCandidate(nodes_[n].pose, q_new, n, cost, nodes_[n].cost, &edges);
  }
  if (absl::Status s = EvaluateCandidates(&edges, /*shared_limit=*/false, nullptr); !s.ok()) {
    return s;
  }
  for (const CandidateEdge& e : edges) {
    // Rewiring n cannot change q_new's cost: n costs more than q_new, so it is
    // not one of q_new's ancestors.
    if (e.alive && nodes_[id].cost + e.risk < nodes_[e.node].cost) SetParent(e.node, id, e.risk);
  }
  return absl::OkStatus();
}

absl::Status Run::MaybeReport() {
  if (!std::isfinite(BestCost())) return absl::OkStatus();
  if (best_.has_value() && !(BestCost() < best_->risk)) return absl::OkStatus();
  std::vector<Pose> waypoints;
  // The trajectory's risk as EvaluateTrajectory computes it: the sum of its
  // piece risks from start to goal. Each edge risk was computed exactly as
  // that piece's risk (same manoeuvre, same samples, same formula), so the
  // total is bit for bit what an independent evaluation gives; the tree's
  // R(start) may differ from it in the last bits (other order of additions).
  double risk = 0.0;
  double length = 0.0;
  const ModelParams& mp = model_.params();
  for (int32_t n = kStart; n >= 0; n = nodes_[n].parent) {
    waypoints.push_back(nodes_[n].pose);
    if (nodes_[n].parent >= 0) risk += nodes_[n].edge_risk;
  }
  if (best_.has_value() && !(risk < best_->risk)) return absl::OkStatus();
  best_pieces_.clear();
  for (size_t i = 0; i + 1 < waypoints.size(); ++i) {
    best_pieces_.push_back(TrajectoryPiece::Manoeuvre(waypoints[i], waypoints[i + 1],
                                                      mp.turn_radius_m, mp.max_climb_rad));
    length += best_pieces_.back().Length();
  }
  PlanImprovement improvement;
  improvement.waypoints = std::move(waypoints);
  improvement.risk = risk;
  improvement.length_m = length;
  improvement.iterations = iterations_;
  improvement.tree_size = static_cast<int64_t>(nodes_.size());
  improvement.elapsed_s = limits_.Elapsed();
  best_ = improvement;
  if (on_improvement_) on_improvement_(improvement);
  return absl::OkStatus();
}

absl::Status Run::Refine() {
  if (!std::isfinite(BestCost())) return absl::OkStatus();
  refine_credit_ += params_.refine_edits;
  bool stale = true;
  for (; refine_credit_ >= 1.0; refine_credit_ -= 1.0) {
    if (static_cast<int64_t>(nodes_.size()) >= params_.max_nodes) break;
    if (stale) {
      // The best trajectory as the tree holds it: start ... goal.
      path_nodes_.clear();
      path_poses_.clear();
      path_risks_.clear();
      for (int32_t n = kStart; n >= 0; n = nodes_[n].parent) {
        path_nodes_.push_back(n);
        path_poses_.push_back(nodes_[n].pose);
        if (nodes_[n].parent >= 0) path_risks_.push_back(nodes_[n].edge_risk);
      }
      stale = false;
    }
    PathRefiner::Edit edit;
    absl::StatusOr<bool> improved = refiner_.TryEdit(path_poses_, path_risks_, refine_rng_, &edit);
    if (!improved.ok()) return improved.status();
    if (!*improved) continue;
    int32_t target = path_nodes_[edit.last];
    if (edit.has_waypoint) {
      const int32_t id = static_cast<int32_t>(nodes_.size());
      nodes_.push_back(Node{edit.waypoint, -1, kInf, kInf, {}});
      SetParent(id, target, edit.risk_out);
      grid_.Insert(id, edit.waypoint.x, edit.waypoint.y);
      target = id;
    }
    // The nodes between keep their other children; only the trajectory leaves them.
    SetParent(path_nodes_[edit.first], target, edit.risk_in);
    stale = true;
  }
  return MaybeReport();
}

absl::Status Run::Guide() {
  if (params_.guide_cell_m <= 0.0) return absl::OkStatus();
  absl::StatusOr<std::vector<Pose>> route = CoarseRiskRoute(
      model_, problem_.start, problem_.goal, params_.guide_cell_m, params_.step_m, evaluator_);
  if (!route.ok()) return route.status();
  for (auto it = route->rbegin(); it != route->rend(); ++it) {
    if (!Admissible(*it)) continue;
    if (absl::Status s = Extend(*it); !s.ok()) return s;
  }
  if (absl::Status s = ConnectStart(); !s.ok()) return s;
  return MaybeReport();
}

absl::StatusOr<PlanResult> Run::Execute() {
  nodes_.push_back(Node{problem_.goal, -1, 0.0, 0.0, {}});
  nodes_.push_back(Node{problem_.start, -1, kInf, kInf, {}});
  grid_.Insert(kGoal, problem_.goal.x, problem_.goal.y);
  grid_.Insert(kStart, problem_.start.x, problem_.start.y);
  const ModelParams& mp = model_.params();

  PlanResult result;
  result.reason = StopReason::kBudgetExhausted;
  // A step stopped by the budget or the token inside its loops (RunStopped)
  // ends the run as the checks at the top of the loop would have.
  absl::Status step = Guide();
  while (step.ok()) {
    if (cancel_.IsCancelled()) {
      result.reason = StopReason::kCancelled;
      break;
    }
    if (!BudgetLeft()) break;
    if (best_.has_value() && best_->risk <= 0.0) {
      result.reason = StopReason::kConverged;
      break;
    }
    ++iterations_;
    bool is_start = false;
    const Pose q_rand = Sample(&is_start);
    const int32_t near = NearestNode(q_rand);
    if (near < 0) continue;
    const DubinsAirplanePath to_near(q_rand, nodes_[near].pose, mp.turn_radius_m, mp.max_climb_rad);
    absl::Status status;
    if (is_start && to_near.Length() <= params_.step_m) {
      status = ConnectStart();
    } else {
      // Steer: the configuration step_m before q_near on the way from q_rand.
      const Pose q_new = to_near.Length() <= params_.step_m
                             ? q_rand
                             : to_near.PoseAt(to_near.Length() - params_.step_m);
      if (!Admissible(q_new)) continue;
      status = Extend(q_new);
    }
    if (status.ok()) status = MaybeReport();
    if (status.ok()) status = Refine();
    step = status;
  }
  if (!step.ok()) {
    if (!IsRunStopped(step)) return step;
    if (cancel_.IsCancelled()) result.reason = StopReason::kCancelled;
  }
  if (!best_.has_value() && result.reason != StopReason::kCancelled) {
    result.reason = StopReason::kNoSolution;
  }
  result.best = best_;
  result.iterations = iterations_;
  result.tree_size = static_cast<int64_t>(nodes_.size());
  result.elapsed_s = limits_.Elapsed();
  result.configurations_evaluated = evaluator_->evaluated();
  if (options_.record_tree) {
    for (size_t n = 0; n < nodes_.size(); ++n) {
      if (nodes_[n].parent >= 0)
        result.tree.push_back({nodes_[n].pose, nodes_[nodes_[n].parent].pose});
    }
  }
  return result;
}

}  // namespace riskplan::rrt_star
