#include <algorithm>
#include <cmath>
#include <limits>

#include "core/flight/dubins.h"
#include "core/planners/risk_rrt_star_run.h"

namespace riskplan::rrt_star {

int32_t Run::NearestNode(const Pose& q) const {
  const auto candidates =
      grid_.Nearest(q.x, q.y, static_cast<size_t>(params_.nearest_candidates) + 1);
  int32_t best = -1;
  double best_length = kInf;
  const ModelParams& mp = model_.params();
  for (const auto& [d2, id] : candidates) {
    if (IsStart(id)) continue;  // a start is never a parent
    const double length =
        DubinsAirplanePath(q, nodes_[id].pose, mp.GroundTurnRadius(), mp.GroundClimbAngle()).Length();
    if (length < best_length) {
      best_length = length;
      best = id;
    }
  }
  return best;
}

std::vector<int32_t> Run::NearCandidates(const Pose& q) const {
  // Euclidean distance is a lower bound of Dubins-airplane length, so the
  // Euclidean neighbours within the radius hold every node that is near by
  // Dubins length; a few times k of them are enough to rank.
  const size_t want = static_cast<size_t>(3 * params_.k_near);
  const auto nearest = grid_.Nearest(q.x, q.y, want);
  std::vector<int32_t> out;
  const double r2 = params_.near_radius_m * params_.near_radius_m;
  for (const auto& [d2, id] : nearest) {
    if (d2 <= r2) out.push_back(id);
  }
  return out;
}

void Run::AddCandidate(const Pose& from, const Pose& to, int32_t node, double base, double limit,
                       std::vector<CandidateEdge>* edges) const {
  const ModelParams& mp = model_.params();
  edges->emplace_back(
      node,
      PieceRisk(TrajectoryPiece::Manoeuvre(from, to, mp.GroundTurnRadius(), mp.GroundClimbAngle()),
                mp.sample_step_m, mp),
      base, limit);
  if (!limited_ || lambda_ == 0.0) return;
  // The Lagrangian's term of the edge: known now for a length and in still
  // air (L / v, PieceRisk's flight time), so it prunes from the first chunk;
  // in wind the time is known once the edge is complete.
  CandidateEdge& e = edges->back();
  const double length = e.rule.piece().Length();
  if (penalise_length_) {
    e.base += lambda_ * length;
  } else if (mp.Calm()) {
    e.base += lambda_ * (length / mp.airspeed_mps);
  } else {
    e.late_weight = lambda_;
  }
}

absl::Status Run::EvaluateCandidates(std::vector<CandidateEdge>* edges, bool shared_limit,
                                     int32_t* winner) {
  const int64_t chunk = params_.MidpointsPerBatch();
  double best = kInf;
  for (const CandidateEdge& e : *edges) best = std::min(best, e.limit);
  if (winner != nullptr) *winner = -1;
  while (true) {
    // Long edges (a fine sample_step_m) make many batches: the budget is
    // honoured between them, not only between iterations.
    if (stop_.Reached()) return RunStopped();
    // One risk batch: the next chunk of every live, unfinished edge, generated
    // and checked now (an inadmissible midpoint drops the edge).
    batch_poses_.clear();
    for (CandidateEdge& e : *edges) {
      e.in_batch = 0;
      if (!e.alive || e.rule.complete()) continue;
      const int64_t done = e.rule.added();
      const int64_t end = e.rule.ChunkEnd(chunk);
      const size_t mark = batch_poses_.size();
      for (int64_t i = done; i < end; ++i) {
        const Pose q = e.rule.Midpoint(i);
        if (!Admissible(q)) {
          e.alive = false;
          e.admissible = false;
          break;
        }
        batch_poses_.push_back(q);
      }
      if (e.alive) {
        e.in_batch = end - done;
      } else {
        batch_poses_.resize(mark);
      }
    }
    batch_risks_.resize(batch_poses_.size());
    if (!batch_poses_.empty()) {
      if (absl::Status s = evaluator_->EvaluateBatch(model_, batch_poses_, batch_risks_); !s.ok()) {
        return s;
      }
    }
    size_t cursor = 0;
    bool pending = false;
    for (size_t n = 0; n < edges->size(); ++n) {
      CandidateEdge& e = (*edges)[n];
      if (!e.alive) continue;
      // The rule adds in EvaluateTrajectory's order, whatever the chunking.
      for (int64_t i = 0; i < e.in_batch; ++i, ++cursor) {
        e.rule.Add(batch_risks_[cursor], batch_poses_[cursor]);
      }
      const double limit = shared_limit ? best : e.limit;
      const double partial = e.rule.PartialRisk();
      if (!(e.base + partial < limit)) {
        e.alive = false;  // risk never decreases with more samples
        continue;
      }
      if (!e.rule.complete()) {
        pending = true;
        continue;
      }
      e.risk = partial;
      if (limited_) {
        e.time_s = e.rule.FlightTimeS();
        e.length_m = e.rule.piece().Length();
        e.total = e.base + partial + e.late_weight * e.time_s;
        if (!(e.total < limit)) {
          e.alive = false;
          continue;
        }
      }
      if (shared_limit) {
        best = limited_ ? e.total : e.base + partial;
        if (winner != nullptr) *winner = static_cast<int32_t>(n);
      }
    }
    if (!pending) break;
  }
  return absl::OkStatus();
}

void Run::SetParent(int32_t child, int32_t parent, double edge_risk, double edge_s,
                    double edge_m) {
  const double new_cost = nodes_[parent].cost + edge_risk;
  Node& c = nodes_[child];
  if (limited_) {
    // The flight time and length to the goal, propagated like the risk.
    const double new_s = nodes_[parent].to_goal_s + edge_s;
    const double new_m = nodes_[parent].to_goal_m + edge_m;
    const double delta_s = new_s - c.to_goal_s;
    const double delta_m = new_m - c.to_goal_m;
    const bool had_parent = c.parent >= 0;
    c.edge_s = edge_s;
    c.edge_m = edge_m;
    c.to_goal_s = new_s;
    c.to_goal_m = new_m;
    if (had_parent && (delta_s != 0.0 || delta_m != 0.0)) {
      std::vector<int32_t> stack(c.children.begin(), c.children.end());
      while (!stack.empty()) {
        const int32_t n = stack.back();
        stack.pop_back();
        nodes_[n].to_goal_s += delta_s;
        nodes_[n].to_goal_m += delta_m;
        stack.insert(stack.end(), nodes_[n].children.begin(), nodes_[n].children.end());
      }
    }
  }
  c.edge_risk = edge_risk;
  if (c.parent >= 0) {
    std::vector<int32_t>& siblings = nodes_[c.parent].children;
    siblings.erase(std::find(siblings.begin(), siblings.end(), child));
  }
  c.parent = parent;
  nodes_[parent].children.push_back(child);
  const double delta = new_cost - c.cost;
  c.cost = new_cost;
  if (!std::isfinite(delta)) return;  // a new node: no descendants yet
  // Propagate the change to every descendant.
  std::vector<int32_t> stack(c.children.begin(), c.children.end());
  while (!stack.empty()) {
    const int32_t n = stack.back();
    stack.pop_back();
    nodes_[n].cost += delta;
    stack.insert(stack.end(), nodes_[n].children.begin(), nodes_[n].children.end());
  }
}

absl::Status Run::BestParent(const Pose& from, const std::vector<int32_t>& candidates, double bound,
                             EdgeChoice* choice) {
  *choice = EdgeChoice{};
  // Branch and bound. Candidates go in order of R(n). A candidate whose R(n)
  // alone reaches the bound cannot win (edge risks are never negative). The
  // cheapest admissible candidate is evaluated first, in full, to set a bound;
  // the others are then evaluated chunk by chunk against the best total found
  // so far, so that a losing edge is dropped as soon as it is known to lose.
  // The winner is the one a full evaluation of every candidate would choose.
  // Under binding limits the same with Key(n) for R(n) and the edge's
  // R + lambda * C for its risk (flight times and lengths are never negative).
  std::vector<int32_t> order = candidates;
  if (limited_) {
    std::stable_sort(order.begin(), order.end(),
                     [&](int32_t a, int32_t b) { return Key(a) < Key(b); });
  } else {
    std::stable_sort(order.begin(), order.end(),
                     [&](int32_t a, int32_t b) { return nodes_[a].cost < nodes_[b].cost; });
  }
  std::vector<CandidateEdge> edges;
  size_t next = 0;
  double best = bound;
  const auto take = [&](const CandidateEdge& e) {
    choice->parent = e.node;
    choice->risk = e.risk;
    choice->time_s = e.time_s;
    choice->length_m = e.length_m;
  };
  // The first admissible candidate, alone.
  int32_t winner = -1;
  while (next < order.size()) {
    const int32_t n = order[next++];
    if (Key(n) >= best) return absl::OkStatus();
    edges.clear();
    AddCandidate(from, nodes_[n].pose, n, Key(n), best, &edges);
    if (absl::Status s = EvaluateCandidates(&edges, /*shared_limit=*/true, &winner); !s.ok()) {
      return s;
    }
    if (edges[0].admissible) break;
  }
  if (winner >= 0) {
    take(edges[winner]);
    best = limited_ ? edges[winner].total : nodes_[choice->parent].cost + choice->risk;
  }
  edges.clear();
  for (; next < order.size(); ++next) {
    const int32_t n = order[next];
    if (Key(n) >= best) break;
    AddCandidate(from, nodes_[n].pose, n, Key(n), best, &edges);
  }
  if (absl::Status s = EvaluateCandidates(&edges, /*shared_limit=*/true, &winner); !s.ok()) {
    return s;
  }
  if (winner >= 0) take(edges[winner]);
  return absl::OkStatus();
}

// The k nearest of `near` by Dubins-airplane length from `from` to them.
std::vector<int32_t> Run::KNearestFrom(const Pose& from, const std::vector<int32_t>& near,
                                       double max_cost) const {
  const ModelParams& mp = model_.params();
  std::vector<std::pair<double, int32_t>> ranked;
  for (int32_t id : near) {
    if (IsStart(id) || Key(id) >= max_cost) continue;
    const double length =
        DubinsAirplanePath(from, nodes_[id].pose, mp.GroundTurnRadius(), mp.GroundClimbAngle()).Length();
    ranked.push_back({length, id});
  }
  std::sort(ranked.begin(), ranked.end());
  if (ranked.size() > static_cast<size_t>(params_.k_near)) ranked.resize(params_.k_near);
  std::vector<int32_t> out;
  for (const auto& [length, id] : ranked) out.push_back(id);
  return out;
}

}  // namespace riskplan::rrt_star
