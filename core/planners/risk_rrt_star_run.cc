#include "core/planners/risk_rrt_star_run.h"

#include <algorithm>
#include <cmath>

#include "core/flight/dubins.h"
#include "core/planners/risk_guide.h"

namespace riskplan::rrt_star {

namespace {
// Under binding limits the start is connected again every this many
// iterations (besides its goal-biased samples): each connection moves lambda.
constexpr int64_t kLimitedConnectEvery = 16;
// SampleInformed's draws before it takes what it has: samples off the
// informed set stay possible, so the search stays complete.
constexpr int kInformedDraws = 8;
}  // namespace

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

bool Run::SampleInformed(Pose* q) {
  bool got = false;
  for (int draw = 0; draw < kInformedDraws; ++draw) {
    if (!SampleUniform(q)) continue;
    got = true;
    if (field_->LeastCostNear(q->x, q->y) <= informed_limit_) return true;
  }
  return got;
}

void Run::UpdateInformedLimit() {
  informed_limit_ = kInf;
  if (field_ == nullptr || params_.guide_informed <= 0.0) return;
  double largest = 0.0;
  for (const MissionRun& r : missions_) {
    if (r.state == MissionState::kRunning) largest = std::max(largest, r.field_route_risk);
  }
  if (largest > 0.0) informed_limit_ = params_.guide_informed * largest;
}

bool Run::SamplePathBiased(size_t m, Pose* q) {
  MissionRun& r = missions_[m];
  if (r.best_pieces.empty()) {
    const ModelParams& mp = model_.params();
    const std::vector<Pose>& w = r.best->waypoints;
    for (size_t i = 0; i + 1 < w.size(); ++i) {
      r.best_pieces.push_back(
          TrajectoryPiece::Manoeuvre(w[i], w[i + 1], mp.GroundTurnRadius(), mp.GroundClimbAngle()));
    }
  }
  const double length = r.best->length_m;
  double s = rng_.Uniform() * length;
  Pose base = r.best_pieces.back().End();
  for (const TrajectoryPiece& piece : r.best_pieces) {
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

Pose Run::Sample(int* start_of) {
  *start_of = -1;
  const double u = rng_.Uniform();
  if (u < params_.goal_bias) {
    *start_of = NextMission(&start_cursor_, Pick::kRunning);
    return missions_[*start_of].spec.start;
  }
  Pose q;
  if (u < params_.goal_bias + params_.path_bias) {
    const int m = NextMission(&path_cursor_, Pick::kWithBest);
    if (m >= 0 && SamplePathBiased(m, &q)) return q;
  }
  if (informed_limit_ < kInf ? SampleInformed(&q) : SampleUniform(&q)) return q;
  // A map with almost nothing flyable: head for a start.
  *start_of = NextMission(&start_cursor_, Pick::kRunning);
  return missions_[*start_of].spec.start;
}

absl::Status Run::ConnectStart(size_t m) {
  if (limited_) return ConnectStartLimited(m);
  const Pose& start = missions_[m].spec.start;
  const int32_t node = StartNode(m);
  // Only a parent that lowers this mission's own risk is of use to it.
  const double own = nodes_[node].cost;
  EdgeChoice choice;
  if (absl::Status s =
          BestParent(start, KNearestFrom(start, NearCandidates(start), own), own, &choice);
      !s.ok()) {
    return s;
  }
  if (choice.parent >= 0) SetParent(node, choice.parent, choice.risk);
  return absl::OkStatus();
}

absl::Status Run::ConnectStartLimited(size_t m) {
  // Every one of the k nearest nodes in full: the start takes the route that
  // ranks best (fitting the limits, best by the objective), and the route
  // with the least R + lambda * C moves lambda.
  const Pose& start = missions_[m].spec.start;
  const int32_t node = StartNode(m);
  std::vector<CandidateEdge> edges;
  for (int32_t n : KNearestFrom(start, NearCandidates(start), kInf)) {
    AddCandidate(start, nodes_[n].pose, n, Key(n), kInf, &edges);
  }
  if (absl::Status s = EvaluateCandidates(&edges, /*shared_limit=*/false, nullptr); !s.ok()) {
    return s;
  }
  RouteNumbers current = StartRoute(m);
  const CandidateEdge* chosen = nullptr;
  const CandidateEdge* key_best = nullptr;
  RouteNumbers key_best_route;
  for (const CandidateEdge& e : edges) {
    if (!e.alive) continue;
    const Node& n = nodes_[e.node];
    const RouteNumbers route{n.cost + e.risk, n.to_goal_s + e.time_s, n.to_goal_m + e.length_m};
    if (key_best == nullptr || e.total < key_best->total) {
      key_best = &e;
      key_best_route = route;
    }
    if (RankBelow(route, current)) {
      chosen = &e;
      current = route;
    }
  }
  if (chosen != nullptr) {
    SetParent(node, chosen->node, chosen->risk, chosen->time_s, chosen->length_m);
  }
  if (key_best != nullptr) AdaptLambda(key_best_route);
  return absl::OkStatus();
}

absl::Status Run::Extend(const Pose& q_new) {
  const ModelParams& mp = model_.params();
  const std::vector<int32_t> near = NearCandidates(q_new);

  // Parent: the k nearest by Dubins length q_new -> n, best by accumulated
  // risk; branch and bound: a node at or above every running mission's
  // solution is useless.
  const double bound = Bound();
  EdgeChoice choice;
  if (absl::Status s = BestParent(q_new, KNearestFrom(q_new, near, bound), bound, &choice);
      !s.ok()) {
    return s;
  }
  const int32_t parent = choice.parent;
  if (parent < 0) return absl::OkStatus();
  const double cost = nodes_[parent].cost + choice.risk;

  const int32_t id = static_cast<int32_t>(nodes_.size());
  nodes_.push_back(Node{q_new, -1, kInf, kInf, {}});
  SetParent(id, parent, choice.risk, choice.time_s, choice.length_m);
  grid_.Insert(id, q_new.x, q_new.y);
  const double key = Key(id);

  // Rewire: neighbours (running missions' starts included) that get cheaper
  // through q_new. Under binding limits: cheaper by Key, and a start is
  // offered the route through q_new by its rank (ConnectStartLimited's rule).
  std::vector<std::pair<double, int32_t>> ranked;
  for (int32_t n : near) {
    if (n == kGoal || n == parent) continue;
    if (limited_) {
      if (!IsStart(n) && !(key < Key(n))) continue;
    } else if (!(cost < nodes_[n].cost)) {
      continue;
    }
    if (IsStart(n) && !Running(n - kFirstStart)) continue;  // its result is out
    const double length =
        DubinsAirplanePath(nodes_[n].pose, q_new, mp.GroundTurnRadius(), mp.GroundClimbAngle()).Length();
    ranked.push_back({length, n});
  }
  std::sort(ranked.begin(), ranked.end());
  if (ranked.size() > static_cast<size_t>(params_.k_near)) ranked.resize(params_.k_near);
  std::vector<CandidateEdge> edges;
  for (const auto& [length, n] : ranked) {
    if (limited_) {
      AddCandidate(nodes_[n].pose, q_new, n, key, IsStart(n) ? kInf : Key(n), &edges);
    } else {
      AddCandidate(nodes_[n].pose, q_new, n, cost, nodes_[n].cost, &edges);
    }
  }
  if (absl::Status s = EvaluateCandidates(&edges, /*shared_limit=*/false, nullptr); !s.ok()) {
    return s;
  }
  for (const CandidateEdge& e : edges) {
    // Rewiring n cannot change q_new's cost: n costs more than q_new, so it is
    // not one of q_new's ancestors (nor is a start, never a parent).
    if (!e.alive) continue;
    if (!limited_) {
      if (nodes_[id].cost + e.risk < nodes_[e.node].cost) SetParent(e.node, id, e.risk);
      continue;
    }
    const Node& q = nodes_[id];
    if (IsStart(e.node)) {
      const RouteNumbers route{q.cost + e.risk, q.to_goal_s + e.time_s, q.to_goal_m + e.length_m};
      if (!RankBelow(route, StartRoute(e.node - kFirstStart))) continue;
    } else if (!(e.total < Key(e.node))) {
      continue;
    }
    SetParent(e.node, id, e.risk, e.time_s, e.length_m);
  }
  return absl::OkStatus();
}

absl::Status Run::Refine() {
  size_t with_solution = 0;
  for (size_t m = 0; m < missions_.size(); ++m) {
    if (Running(m) && std::isfinite(nodes_[StartNode(m)].cost)) ++with_solution;
  }
  if (with_solution == 0) return absl::OkStatus();
  refine_credit_ += RefineEditsPerIteration(params_.refine_edits, with_solution);
  // The path of the mission last traced, while no edit has changed the tree.
  int traced = -1;
  for (; refine_credit_ >= 1.0; refine_credit_ -= 1.0) {
    if (static_cast<int64_t>(nodes_.size()) >= params_.max_nodes) break;
    // Edits go round-robin over the running missions with a solution.
    const int m = NextMission(&refine_cursor_, Pick::kWithCost);
    if (m != traced) {
      TracePath(m);
      traced = m;
    }
    PathRefiner::Edit edit;
    absl::StatusOr<bool> improved = refiner_.TryEdit(path_poses_, path_risks_, refine_rng_, &edit);
    if (!improved.ok()) return improved.status();
    if (!*improved) continue;
    double in_s = 0.0;
    double in_m = 0.0;
    double out_s = 0.0;
    double out_m = 0.0;
    if (limited_) {
      // Under binding limits an edit must lower R + lambda * C of the pieces
      // it replaces, and keep the start's route within the limits if it was.
      const Pose& to = edit.has_waypoint ? edit.waypoint : path_poses_[edit.last];
      PieceTimeLength(path_poses_[edit.first], to, &in_s, &in_m);
      if (edit.has_waypoint) {
        PieceTimeLength(edit.waypoint, path_poses_[edit.last], &out_s, &out_m);
      }
      double old_risk = 0.0;
      double old_s = 0.0;
      double old_m = 0.0;
      for (size_t i = edit.first; i < edit.last; ++i) {
        old_risk += path_risks_[i];
        old_s += path_s_[i];
        old_m += path_m_[i];
      }
      const double d_risk = edit.risk_in + edit.risk_out - old_risk;
      const double d_s = in_s + out_s - old_s;
      const double d_m = in_m + out_m - old_m;
      const RouteNumbers now = StartRoute(m);
      const bool fits_now = Fits(now);
      if (fits_now &&
          !Fits(RouteNumbers{now.risk + d_risk, now.time_s + d_s, now.length_m + d_m})) {
        continue;
      }
      // MIN_RISK on a fitting route: any edit that keeps it fitting (it
      // lowers the risk), so the route uses the slack up to the limit.
      const bool use_slack = fits_now && limits_.objective == PlanObjective::kMinRisk;
      if (!use_slack && !(d_risk + lambda_ * (penalise_length_ ? d_m : d_s) < 0.0)) continue;
    }
    int32_t target = path_nodes_[edit.last];
    if (edit.has_waypoint) {
      const int32_t id = static_cast<int32_t>(nodes_.size());
      nodes_.push_back(Node{edit.waypoint, -1, kInf, kInf, {}});
      SetParent(id, target, edit.risk_out, out_s, out_m);
      grid_.Insert(id, edit.waypoint.x, edit.waypoint.y);
      target = id;
    }
    // The nodes between keep their other children; only the trajectory
    // leaves them. Their R, and that of every mission flying through them,
    // only falls (under binding limits: their Key).
    SetParent(path_nodes_[edit.first], target, edit.risk_in, in_s, in_m);
    traced = -1;
  }
  MaybeReport();
  return absl::OkStatus();
}

absl::Status Run::Guide(size_t m) {
  if (params_.guide) {
    if (absl::Status s = GuideByField(m); !s.ok()) return s;
  }
  if (params_.guide_cell_m <= 0.0) return absl::OkStatus();
  // The coarse grid depends on the model alone: built once for every start.
  if (!guide_grid_.has_value()) {
    absl::StatusOr<CoarseRiskGrid> grid =
        CoarseRiskGrid::Build(model_, params_.guide_cell_m, evaluator_);
    if (!grid.ok()) return grid.status();
    guide_grid_ = std::move(*grid);
  }
  const std::vector<Pose> route =
      guide_grid_->Route(missions_[m].spec.start, goal_, params_.step_m);
  for (auto it = route.rbegin(); it != route.rend(); ++it) {
    if (!Admissible(*it)) continue;
    if (absl::Status s = Extend(*it); !s.ok()) return s;
  }
  if (absl::Status s = ConnectStart(m); !s.ok()) return s;
  MaybeReport();
  return absl::OkStatus();
}

absl::Status Run::Iterate() {
  const ModelParams& mp = model_.params();
  ++iterations_;
  int start_of = -1;
  const Pose q_rand = Sample(&start_of);
  const int32_t near = NearestNode(q_rand);
  if (near < 0) return absl::OkStatus();
  const DubinsAirplanePath to_near(q_rand, nodes_[near].pose, mp.GroundTurnRadius(), mp.GroundClimbAngle());
  if (start_of >= 0 && to_near.Length() <= params_.step_m) {
    if (absl::Status s = ConnectStart(start_of); !s.ok()) return s;
  } else {
    // Steer: the configuration step_m before q_near on the way from q_rand.
    const Pose q_new = to_near.Length() <= params_.step_m
                           ? q_rand
                           : to_near.PoseAt(to_near.Length() - params_.step_m);
    if (!Admissible(q_new)) return absl::OkStatus();
    if (absl::Status s = Extend(q_new); !s.ok()) return s;
  }
  if (limited_ && iterations_ % kLimitedConnectEvery == 0 &&
      Running(0)) {
    if (absl::Status s = ConnectStart(0); !s.ok()) return s;
  }
  MaybeReport();
  return Refine();
}

void Run::Seed() {
  nodes_.push_back(Node{goal_, -1, 0.0, 0.0, {}});
  grid_.Insert(kGoal, goal_.x, goal_.y);
  for (size_t m = 0; m < missions_.size(); ++m) {
    const Pose& start = missions_[m].spec.start;
    nodes_.push_back(Node{start, -1, kInf, kInf, {}});
    grid_.Insert(StartNode(m), start.x, start.y);
  }
  if (initial_tree_ == nullptr) return;
  // The tree's node i > 0 becomes node i + M, after the starts: the layout
  // (goal, starts, grown nodes) stays that of a run from the goal. Costs and
  // edge risks are copied as they are: each edge risk is the exact piece
  // risk under the same model, so reported risks stay exact sums.
  const std::vector<GoalTreeNode>& tree = initial_tree_->nodes;
  const int32_t shift = static_cast<int32_t>(missions_.size());
  const auto renumber = [shift](int32_t n) { return n == kGoal ? kGoal : n + shift; };
  nodes_.reserve(nodes_.size() + tree.size() - 1);
  for (size_t i = 1; i < tree.size(); ++i) {
    const GoalTreeNode& t = tree[i];
    nodes_.push_back(Node{t.pose, renumber(t.parent), t.cost, t.edge_risk, {}});
  }
  for (size_t n = kFirstStart + missions_.size(); n < nodes_.size(); ++n) {
    nodes_[nodes_[n].parent].children.push_back(static_cast<int32_t>(n));
    grid_.Insert(static_cast<int32_t>(n), nodes_[n].pose.x, nodes_[n].pose.y);
  }
  initial_tree_ = nullptr;
}

bool Run::ExportTree(GoalTree* out) const {
  out->nodes.clear();
  if (failed_) return false;
  // Starts are never parents, so dropping them leaves every other parent in
  // the tree: node n > M becomes n - M.
  const int32_t shift = static_cast<int32_t>(missions_.size());
  out->nodes.reserve(nodes_.size() - missions_.size());
  for (size_t n = 0; n < nodes_.size(); ++n) {
    if (IsStart(static_cast<int32_t>(n))) continue;
    const Node& node = nodes_[n];
    const int32_t parent = node.parent <= kGoal ? node.parent : node.parent - shift;
    out->nodes.push_back(GoalTreeNode{node.pose, parent, node.cost, node.edge_risk});
  }
  return true;
}

void Run::Execute() {
  const bool from_tree = initial_tree_ != nullptr;
  Seed();
  if (from_tree) {
    // Each start first takes what the tree already offers: a tree at
    // max_nodes still answers, and the guide routes build on a solution.
    for (size_t m = 0; m < missions_.size(); ++m) {
      if (absl::Status s = ConnectStart(m); !s.ok()) {
        if (!IsRunStopped(s)) return FailRunning(s);
        break;
      }
    }
    MaybeReport();
  }
  // A step stopped by the StopCondition inside its loops (RunStopped) is
  // dropped, as an iteration the budget would not have begun; UpdateMissions
  // then ends the missions it stopped for (the token: all; a deadline: the
  // earliest) and the others go on.
  for (size_t m = 0; m < missions_.size(); ++m) {
    if (!UpdateMissions()) return;
    if (!Running(m)) continue;
    if (absl::Status s = Guide(m); !s.ok() && !IsRunStopped(s)) return FailRunning(s);
  }
  UpdateInformedLimit();
  while (UpdateMissions()) {
    if (absl::Status s = Iterate(); !s.ok() && !IsRunStopped(s)) return FailRunning(s);
  }
}

}  // namespace riskplan::rrt_star
