#include "core/risk_rrt_star.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "core/dubins.h"
#include "core/path_refiner.h"
#include "core/random.h"
#include "core/risk_guide.h"
#include "core/spatial_grid.h"
#include "core/trajectory.h"

namespace riskplan {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

struct Params {
  double step_m = 400.0;
  double goal_bias = 0.05;
  double path_bias = 0.2;
  double k_near = 8;
  double near_radius_m = 0.0;  // 0: 2.5 * step_m
  double nearest_candidates = 8;
  double max_nodes = 200000;
  double risk_cache_log2 = 0;
  double batch_chunk = 16;
  double refine_edits = 8;
  double refine_scale_m = 0.0;  // 0: step_m / 2
  double guide_cell_m = 100.0;  // 0: no guide route
};

absl::StatusOr<Params> ParseParams(const std::map<std::string, double>& given) {
  Params p;
  const std::vector<PlannerParamInfo>& info = RiskRrtStar::ParamInfo();
  for (const auto& [name, value] : given) {
    auto it = std::find_if(info.begin(), info.end(),
                           [&](const PlannerParamInfo& i) { return i.name == name; });
    if (it == info.end()) {
      std::vector<std::string> names;
      for (const PlannerParamInfo& i : info) names.push_back(i.name);
      return absl::InvalidArgumentError(
          absl::StrFormat("unknown planner parameter '%s' for RISK_RRT_STAR; known: %s", name,
                          absl::StrJoin(names, ", ")));
    }
    if (!std::isfinite(value) || value < it->min_value || value > it->max_value) {
      return absl::InvalidArgumentError(
          absl::StrFormat("planner parameter '%s' has value %g; it must be in [%g, %g]", name,
                          value, it->min_value, it->max_value));
    }
    if (name == "step_m") p.step_m = value;
    if (name == "goal_bias") p.goal_bias = value;
    if (name == "path_bias") p.path_bias = value;
    if (name == "k_near") p.k_near = std::floor(value);
    if (name == "near_radius_m") p.near_radius_m = value;
    if (name == "nearest_candidates") p.nearest_candidates = std::floor(value);
    if (name == "max_nodes") p.max_nodes = std::floor(value);
    if (name == "risk_cache_log2") p.risk_cache_log2 = std::floor(value);
    if (name == "batch_chunk") p.batch_chunk = std::floor(value);
    if (name == "refine_edits") p.refine_edits = value;
    if (name == "refine_scale_m") p.refine_scale_m = value;
    if (name == "guide_cell_m") p.guide_cell_m = value;
  }
  if (p.near_radius_m == 0.0) p.near_radius_m = 2.5 * p.step_m;
  if (p.refine_scale_m == 0.0) p.refine_scale_m = 0.5 * p.step_m;
  if (p.goal_bias + p.path_bias > 0.9) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "planner parameters goal_bias (%g) + path_bias (%g) must not exceed 0.9: uniform "
        "samples keep the search complete",
        p.goal_bias, p.path_bias));
  }
  return p;
}

struct Node {
  Pose pose;
  int32_t parent = -1;
  double cost = kInf;       // R(q): risk from here to the goal along the tree
  double edge_risk = kInf;  // risk of the edge to the parent (a piece risk)
  std::vector<int32_t> children;
};

// A candidate edge, evaluated progressively: its midpoints are generated,
// checked and sent to the risk batches a chunk at a time, and it is dropped as
// soon as a midpoint is inadmissible or base + its partial risk reaches its
// limit (risk only grows as samples are added), so a losing edge costs only
// the chunks it took to lose.
struct CandidateEdge {
  int32_t node = -1;  // the tree node at the other end
  TrajectoryPiece piece;
  int parts = 0;        // K midpoints
  double ds = 0.0;      // length of one part
  double base = 0.0;    // risk added to the edge's own: R of its far end
  double limit = kInf;  // drop when base + partial risk >= limit
  double sum = 0.0;     // sum of M over midpoints [0, done), in order
  int done = 0;
  int in_batch = 0;  // midpoints of this edge in the current batch
  bool alive = true;
  bool admissible = true;  // false once an inadmissible midpoint was found
  double risk = kInf;      // set when complete: exactly the piece risk of EvaluateTrajectory
};

// One planning run: all state of a Plan() call.
class Run {
 public:
  Run(const PlanningProblem& problem, const PlanOptions& options, const Params& params,
      RiskEvaluator* evaluator, const CancellationToken& cancel,
      const ImprovementCallback& on_improvement)
      : problem_(problem),
        model_(*problem.model),
        options_(options),
        params_(params),
        evaluator_(evaluator),
        cancel_(cancel),
        on_improvement_(on_improvement),
        rng_(options.seed),
        refine_rng_(options.seed ^ 0x5265666e65526e67ULL),
        refiner_(model_, evaluator, params.refine_scale_m,
                 params.batch_chunk > 0 ? static_cast<int>(params.batch_chunk)
                                        : std::numeric_limits<int>::max()),
        grid_(model_.map().x0(), model_.map().y0(), model_.map().width_m(), model_.map().height_m(),
              std::max(50.0, params.near_radius_m / 2.0)) {}

  absl::StatusOr<PlanResult> Execute();

 private:
  bool Admissible(const Pose& q) const {
    return model_.CheckConfiguration(q) == ViolationKind::kNone;
  }
  double Elapsed() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time_).count();
  }
  bool BudgetLeft() const {
    if (options_.budget.max_iterations > 0 && iterations_ >= options_.budget.max_iterations) {
      return false;
    }
    if (options_.budget.max_time_s > 0.0 && Elapsed() >= options_.budget.max_time_s) return false;
    return static_cast<double>(nodes_.size()) < params_.max_nodes;
  }
  double BestCost() const { return nodes_[kStart].cost; }

  bool SampleUniform(Pose* q);
  bool SamplePathBiased(Pose* q);
  Pose Sample(bool* is_start);
  int32_t NearestNode(const Pose& q) const;
  std::vector<int32_t> NearCandidates(const Pose& q) const;
  // Appends the edge flown from `from` to `to`; its midpoints are generated
  // and checked by EvaluateCandidates.
  void AddCandidate(const Pose& from, const Pose& to, int32_t node, double base, double limit,
                    std::vector<CandidateEdge>* edges) const;
  // Evaluates the edges progressively, dropping each as soon as a midpoint is
  // inadmissible or base + partial risk reaches its limit; with `shared_limit`
  // the limit is the best total base + risk completed so far (starting at the
  // edges' limit), and *winner is the index of the edge that set it (-1: none).
  // An edge that completes is admissible and has exactly the risk a full
  // evaluation of admissible edges alone would give it, so the outcome does
  // not depend on when an inadmissible edge is found out.
  absl::Status EvaluateCandidates(std::vector<CandidateEdge>* edges, bool shared_limit,
                                  int32_t* winner);
  void SetParent(int32_t child, int32_t parent, double edge_risk);
  // The candidate parent of `from` with the least R(n) + R(from -> n) below
  // `bound`, as (node, edge risk); node -1 when none is admissible or below.
  absl::Status BestParent(const Pose& from, const std::vector<int32_t>& candidates, double bound,
                          int32_t* parent, double* edge_risk);
  std::vector<int32_t> KNearestFrom(const Pose& from, const std::vector<int32_t>& near,
                                    double max_cost) const;
  absl::Status ConnectStart();
  absl::Status Extend(const Pose& q_new);
  absl::Status MaybeReport();
  // Local improvement of the best trajectory between tree iterations
  // (core/path_refiner.h): an accepted edit becomes part of the tree (a new
  // node for its waypoint, the trajectory's nodes re-parented), so the tree's
  // R(start) is the improved risk and later samples build on it.
  absl::Status Refine();
  // Seeds the tree with the coarse guide route (core/risk_guide.h), its
  // waypoints added from the goal's side by the ordinary extension.
  absl::Status Guide();

  static constexpr int32_t kGoal = 0;
  static constexpr int32_t kStart = 1;

  const PlanningProblem& problem_;
  const RiskModel& model_;
  const PlanOptions& options_;
  const Params params_;
  RiskEvaluator* evaluator_;
  const CancellationToken& cancel_;
  const ImprovementCallback& on_improvement_;
  Rng rng_;
  Rng refine_rng_;  // the refiner's own stream: the tree's samples do not depend on it
  PathRefiner refiner_;
  double refine_credit_ = 0.0;
  SpatialGrid grid_;
  std::vector<Node> nodes_;
  std::chrono::steady_clock::time_point start_time_;
  int64_t iterations_ = 0;
  std::optional<PlanImprovement> best_;
  std::vector<TrajectoryPiece> best_pieces_;
  // Scratch buffers reused between iterations.
  std::vector<int32_t> path_nodes_;
  std::vector<Pose> path_poses_;
  std::vector<double> path_risks_;
  std::vector<Pose> batch_poses_;
  std::vector<ConfigurationRisk> batch_risks_;
};

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

int32_t Run::NearestNode(const Pose& q) const {
  const auto candidates =
      grid_.Nearest(q.x, q.y, static_cast<size_t>(params_.nearest_candidates) + 1);
  int32_t best = -1;
  double best_length = kInf;
  const ModelParams& mp = model_.params();
  for (const auto& [d2, id] : candidates) {
    if (id == kStart) continue;
    const double length =
        DubinsAirplanePath(q, nodes_[id].pose, mp.turn_radius_m, mp.max_climb_rad).Length();
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
  CandidateEdge edge;
  edge.node = node;
  edge.base = base;
  edge.limit = limit;
  edge.piece = TrajectoryPiece::Manoeuvre(from, to, mp.turn_radius_m, mp.max_climb_rad);
  edge.parts = PartCount(edge.piece.Length(), mp.sample_step_m);
  edge.ds = edge.parts > 0 ? edge.piece.Length() / edge.parts : 0.0;
  edges->push_back(std::move(edge));
}

absl::Status Run::EvaluateCandidates(std::vector<CandidateEdge>* edges, bool shared_limit,
                                     int32_t* winner) {
  const ModelParams& mp = model_.params();
  const double per_metre = mp.failure_rate_per_s / mp.airspeed_mps;
  const int chunk = params_.batch_chunk > 0 ? static_cast<int>(params_.batch_chunk)
                                            : std::numeric_limits<int>::max();
  double best = kInf;
  for (const CandidateEdge& e : *edges) best = std::min(best, e.limit);
  if (winner != nullptr) *winner = -1;
  while (true) {
    // One risk batch: the next chunk of every live, unfinished edge, generated
    // and checked now (an inadmissible midpoint drops the edge).
    batch_poses_.clear();
    for (CandidateEdge& e : *edges) {
      e.in_batch = 0;
      if (!e.alive || e.done == e.parts) continue;
      const int end = e.parts - e.done > chunk ? e.done + chunk : e.parts;
      const size_t mark = batch_poses_.size();
      for (int i = e.done; i < end; ++i) {
        const Pose q = e.piece.PoseAt((i + 0.5) * e.ds);
        if (!Admissible(q)) {
          e.alive = false;
          e.admissible = false;
          break;
        }
        batch_poses_.push_back(q);
      }
      if (e.alive) {
        e.in_batch = end - e.done;
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
      // Same order of additions as EvaluateTrajectory's single pass.
      for (int i = 0; i < e.in_batch; ++i) e.sum += batch_risks_[cursor++].risk;
      e.done += e.in_batch;
      const double limit = shared_limit ? best : e.limit;
      // (lambda / v) * (sum M) * ds: exactly the piece risk of EvaluateTrajectory.
      const double partial = per_metre * e.sum * e.ds;
      if (!(e.base + partial < limit)) {
        e.alive = false;  // risk never decreases with more samples
        continue;
      }
      if (e.done < e.parts) {
        pending = true;
        continue;
      }
      e.risk = partial;
      if (shared_limit) {
        best = e.base + partial;
        if (winner != nullptr) *winner = static_cast<int32_t>(n);
      }
    }
    if (!pending) break;
  }
  return absl::OkStatus();
}

void Run::SetParent(int32_t child, int32_t parent, double edge_risk) {
  const double new_cost = nodes_[parent].cost + edge_risk;
  Node& c = nodes_[child];
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
                             int32_t* parent, double* edge_risk) {
  *parent = -1;
  *edge_risk = kInf;
  // Branch and bound. Candidates go in order of R(n). A candidate whose R(n)
  // alone reaches the bound cannot win (edge risks are never negative). The
  // cheapest admissible candidate is evaluated first, in full, to set a bound;
  // the others are then evaluated chunk by chunk against the best total found
  // so far, so that a losing edge is dropped as soon as it is known to lose.
  // The winner is the one a full evaluation of every candidate would choose.
  std::vector<int32_t> order = candidates;
  std::stable_sort(order.begin(), order.end(),
                   [&](int32_t a, int32_t b) { return nodes_[a].cost < nodes_[b].cost; });
  std::vector<CandidateEdge> edges;
  size_t next = 0;
  double best = bound;
  // The first admissible candidate, alone.
  int32_t winner = -1;
  while (next < order.size()) {
    const int32_t n = order[next++];
    if (nodes_[n].cost >= best) return absl::OkStatus();
    edges.clear();
    AddCandidate(from, nodes_[n].pose, n, nodes_[n].cost, best, &edges);
    if (absl::Status s = EvaluateCandidates(&edges, /*shared_limit=*/true, &winner); !s.ok()) {
      return s;
    }
    if (edges[0].admissible) break;
  }
  if (winner >= 0) {
    *parent = edges[winner].node;
    *edge_risk = edges[winner].risk;
    best = nodes_[*parent].cost + *edge_risk;
  }
  edges.clear();
  for (; next < order.size(); ++next) {
    const int32_t n = order[next];
    if (nodes_[n].cost >= best) break;
    AddCandidate(from, nodes_[n].pose, n, nodes_[n].cost, best, &edges);
  }
  if (absl::Status s = EvaluateCandidates(&edges, /*shared_limit=*/true, &winner); !s.ok()) {
    return s;
  }
  if (winner >= 0) {
    *parent = edges[winner].node;
    *edge_risk = edges[winner].risk;
  }
  return absl::OkStatus();
}

// The k nearest of `near` by Dubins-airplane length from `from` to them.
std::vector<int32_t> Run::KNearestFrom(const Pose& from, const std::vector<int32_t>& near,
                                       double max_cost) const {
  const ModelParams& mp = model_.params();
  std::vector<std::pair<double, int32_t>> ranked;
  for (int32_t id : near) {
    if (id == kStart || nodes_[id].cost >= max_cost) continue;
    const double length =
        DubinsAirplanePath(from, nodes_[id].pose, mp.turn_radius_m, mp.max_climb_rad).Length();
    ranked.push_back({length, id});
  }
  std::sort(ranked.begin(), ranked.end());
  if (ranked.size() > static_cast<size_t>(params_.k_near)) ranked.resize(params_.k_near);
  std::vector<int32_t> out;
  for (const auto& [length, id] : ranked) out.push_back(id);
  return out;
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
  improvement.elapsed_s = Elapsed();
  best_ = improvement;
  if (on_improvement_) on_improvement_(improvement);
  return absl::OkStatus();
}

absl::Status Run::Refine() {
  if (!std::isfinite(BestCost())) return absl::OkStatus();
  refine_credit_ += params_.refine_edits;
  bool stale = true;
  for (; refine_credit_ >= 1.0; refine_credit_ -= 1.0) {
    if (static_cast<double>(nodes_.size()) >= params_.max_nodes) break;
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
  start_time_ = std::chrono::steady_clock::now();
  nodes_.push_back(Node{problem_.goal, -1, 0.0, 0.0, {}});
  nodes_.push_back(Node{problem_.start, -1, kInf, kInf, {}});
  grid_.Insert(kGoal, problem_.goal.x, problem_.goal.y);
  grid_.Insert(kStart, problem_.start.x, problem_.start.y);
  const ModelParams& mp = model_.params();

  if (absl::Status s = Guide(); !s.ok()) return s;
  PlanResult result;
  result.reason = StopReason::kBudgetExhausted;
  while (true) {
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
    if (!status.ok()) return status;
    if (absl::Status s = MaybeReport(); !s.ok()) return s;
    if (absl::Status s = Refine(); !s.ok()) return s;
  }
  if (!best_.has_value() && result.reason != StopReason::kCancelled) {
    result.reason = StopReason::kNoSolution;
  }
  result.best = best_;
  result.iterations = iterations_;
  result.tree_size = static_cast<int64_t>(nodes_.size());
  result.elapsed_s = Elapsed();
  result.configurations_evaluated = evaluator_->evaluated();
  if (options_.record_tree) {
    for (size_t n = 0; n < nodes_.size(); ++n) {
      if (nodes_[n].parent >= 0)
        result.tree.push_back({nodes_[n].pose, nodes_[nodes_[n].parent].pose});
    }
  }
  return result;
}

}  // namespace

const std::vector<PlannerParamInfo>& RiskRrtStar::ParamInfo() {
  static const auto* info = new std::vector<PlannerParamInfo>{
      {"step_m", 400.0, 10.0, 5000.0, "largest edge added by one extension (Delta_step), m"},
      {"goal_bias", 0.05, 0.0, 0.9, "share of samples that are the start configuration"},
      {"path_bias", 0.2, 0.0, 0.9, "share of samples drawn around the best trajectory so far"},
      {"k_near", 8, 1, 100, "neighbours considered as parents and for rewiring"},
      {"near_radius_m", 0.0, 0.0, 20000.0, "largest distance of a neighbour, m (0: 2.5 * step_m)"},
      {"nearest_candidates", 8, 1, 100,
       "Euclidean candidates ranked by Dubins length to find the nearest node"},
      {"max_nodes", 200000, 10, 300000,
       "largest tree (about 130 bytes a node); the run ends when it is reached"},
      {"batch_chunk", 16, 0, 100000,
       "midpoints per candidate edge in one risk batch; a losing edge is dropped between "
       "batches (0: whole edges, one batch per step)"},
      {"refine_edits", 8, 0, 100,
       "local edits of the best trajectory tried per tree iteration once a solution exists "
       "(fractions accumulate; 0: off)"},
      {"refine_scale_m", 0.0, 0.0, 5000.0,
       "largest standard deviation of an edit's new waypoint, horizontally, m (0: step_m / 2)"},
      {"guide_cell_m", 100.0, 0.0, 2000.0,
       "cell of the coarse risk grid whose cheapest route seeds the tree, m (0: no guide)"},
      {"risk_cache_log2", 0, 0, 20,
       "log2 of the entries of the exact configuration-risk cache (40 B each) used when no "
       "external evaluator is given; 0 turns it off"},
  };
  return *info;
}

absl::StatusOr<PlanResult> RiskRrtStar::Plan(const PlanningProblem& problem,
                                             const PlanOptions& options,
                                             const CancellationToken& cancel,
                                             const ImprovementCallback& on_improvement) {
  if (absl::Status s = CheckEndpoints(problem); !s.ok()) return s;
  if (absl::Status s = CheckRequestObstacles(PlannerAlgorithm::kRiskRrtStar, options); !s.ok()) {
    return s;
  }
  const PlannerBudget& b = options.budget;
  if (!(b.max_time_s >= 0.0) || !std::isfinite(b.max_time_s) || b.max_iterations < 0 ||
      (b.max_time_s == 0.0 && b.max_iterations == 0)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "budget: max_time_s (%g) and max_iterations (%d) must be >= 0 and not both 0", b.max_time_s,
        b.max_iterations));
  }
  auto params = ParseParams(options.params);
  if (!params.ok()) return params.status();
  // Without an evaluator of the caller's: direct evaluation, or on request an
  // exact cache of kernel sites. (On demo-city about 40 % of the requests of a
  // run repeat a site, but a table large enough to hold them misses the CPU
  // caches, and measured no faster than recomputing.)
  std::unique_ptr<RiskEvaluator> own;
  RiskEvaluator* evaluator = evaluator_;
  if (evaluator == nullptr) {
    if (params->risk_cache_log2 > 0) {
      own = std::make_unique<CachingRiskEvaluator>(static_cast<int>(params->risk_cache_log2));
    } else {
      own = std::make_unique<DirectRiskEvaluator>();
    }
    evaluator = own.get();
  }
  Run run(problem, options, *params, evaluator, cancel, on_improvement);
  return run.Execute();
}

}  // namespace riskplan
