#include "core/planners/state_lattice.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <utility>

#include "absl/strings/str_format.h"
#include "core/flight/dubins.h"
#include "core/flight/piece_risk.h"
#include "core/flight/trajectory_piece.h"

namespace riskplan {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// Midpoints per risk batch.
constexpr size_t kBatchPoses = size_t{1} << 15;
// A piece with more parts than this is not an edge (a spiral of many turns).
constexpr int64_t kMaxEdgeParts = 100000;
// The 16 grid moves of a primitive: 8 adjacent cells and 8 knight's moves.
constexpr int kMoves[16][2] = {{1, 0},   {1, 1},   {0, 1},  {-1, 1}, {-1, 0}, {-1, -1},
                               {0, -1},  {1, -1},  {2, 1},  {1, 2},  {-1, 2}, {-2, 1},
                               {-2, -1}, {-1, -2}, {1, -2}, {2, -1}};
constexpr double kPrimitiveStretch = 1.25;
constexpr double kConnectStretch = 1.3;

}  // namespace

absl::Status CheckLatticeOptions(const LatticeOptions& o) {
  if (!(o.spacing_m >= 10.0) || !std::isfinite(o.spacing_m)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "lattice spacing_m has value %g; it must be >= 10 and finite", o.spacing_m));
  }
  if (o.headings < 4 || o.headings > 64) {
    return absl::InvalidArgumentError(
        absl::StrFormat("lattice headings has value %d; it must be in [4, 64]", o.headings));
  }
  if (o.level_offsets_m.empty() || o.level_offsets_m.size() > 8) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "lattice level_offsets_m has %d entries; it must have 1 to 8", o.level_offsets_m.size()));
  }
  for (size_t l = 0; l < o.level_offsets_m.size(); ++l) {
    if (!(o.level_offsets_m[l] >= 0.0) || !std::isfinite(o.level_offsets_m[l])) {
      return absl::InvalidArgumentError(
          absl::StrFormat("lattice level_offsets_m[%d] has value %g; it must be >= 0 and finite", l,
                          o.level_offsets_m[l]));
    }
  }
  if (!(o.risk_step_m >= 0.0) || !std::isfinite(o.risk_step_m)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "lattice risk_step_m has value %g; it must be >= 0 and finite", o.risk_step_m));
  }
  if (!(o.connect_radius_m >= 0.0) || !std::isfinite(o.connect_radius_m)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "lattice connect_radius_m has value %g; it must be >= 0 and finite", o.connect_radius_m));
  }
  return absl::OkStatus();
}

StateLattice::StateLattice(const RiskModel& model, const LatticeOptions& options)
    : model_(&model), options_(options) {}

double StateLattice::RiskStep(const RiskModel& m) const {
  return std::max(options_.risk_step_m, m.params().sample_step_m);
}

absl::StatusOr<std::unique_ptr<StateLattice>> StateLattice::Create(const RiskModel& model,
                                                                   const LatticeOptions& options) {
  if (absl::Status s = CheckLatticeOptions(options); !s.ok()) return s;
  std::unique_ptr<StateLattice> g(new StateLattice(model, options));
  const RiskModel& m = model;
  const RiskMap& map = m.map();
  const ModelParams& mp = m.params();
  if (g->options_.connect_radius_m == 0.0) g->options_.connect_radius_m = 2.0 * options.spacing_m;
  g->nx_ = std::max(1, static_cast<int>(std::floor(map.width_m() / options.spacing_m)));
  g->ny_ = std::max(1, static_cast<int>(std::floor(map.height_m() / options.spacing_m)));
  g->levels_ = static_cast<int>(options.level_offsets_m.size());
  g->x0_ = map.x0();
  g->y0_ = map.y0();
  g->width_m_ = map.width_m();
  g->height_m_ = map.height_m();
  const int H = options.headings;
  const int64_t n = static_cast<int64_t>(g->nx_) * g->ny_ * H * g->levels_;
  if (n > (int64_t{1} << 30)) {
    return absl::InvalidArgumentError(
        absl::StrFormat("lattice of %d states is too large; raise spacing_m or lower headings", n));
  }
  g->poses_.resize(n);
  g->valid_.assign(n, 0);
  for (int j = 0; j < g->ny_; ++j) {
    for (int i = 0; i < g->nx_; ++i) {
      const double x = map.x0() + std::min((i + 0.5) * options.spacing_m, map.width_m());
      const double y = map.y0() + std::min((j + 0.5) * options.spacing_m, map.height_m());
      int ci = 0;
      int cj = 0;
      if (!map.CellOf(x, y, &ci, &cj) || map.nofly(ci, cj)) continue;
      const double low = m.SafeAltitude(ci, cj);
      const double high = map.terrain(ci, cj) + mp.max_agl_m;
      if (!(low <= high)) continue;
      double previous_z = -kInf;
      for (int l = 0; l < g->levels_; ++l) {
        const double z = std::min(low + options.level_offsets_m[l], high);
        if (z == previous_z) continue;  // clamped onto the level below
        previous_z = z;
        for (int h = 0; h < H; ++h) {
          const Pose p{x, y, z, h * kTwoPi / H};
          if (m.CheckConfiguration(p) != ViolationKind::kNone) continue;
          const int32_t s = g->StateOf(i, j, h, l);
          g->poses_[s] = p;
          g->valid_[s] = 1;
          ++g->valid_states_;
        }
      }
    }
  }
  // Primitives, by the heading they end in.
  g->into_.assign(H, {});
  const double radius = mp.GroundTurnRadius();
  const double climb = mp.GroundClimbAngle();
  for (int h1 = 0; h1 < H; ++h1) {
    for (const auto& move : kMoves) {
      const double dx = move[0] * options.spacing_m;
      const double dy = move[1] * options.spacing_m;
      for (int dh = -1; dh <= 1; ++dh) {
        const int h0 = (h1 - dh + H) % H;
        const DubinsAirplanePath path(Pose{0.0, 0.0, 0.0, h0 * kTwoPi / H},
                                      Pose{dx, dy, 0.0, h1 * kTwoPi / H}, radius, climb);
        if (path.HorizontalLength() <= kPrimitiveStretch * std::hypot(dx, dy)) {
          g->into_[h1].push_back(Primitive{move[0], move[1], h0});
        }
      }
    }
    g->max_into_ = std::max(g->max_into_, g->into_[h1].size());
  }
  return g;
}

int64_t StateLattice::PositionNear(double x, double y) const {
  const double u = x - x0_;
  const double v = y - y0_;
  if (!(u >= 0.0 && u <= width_m_ && v >= 0.0 && v <= height_m_)) return -1;
  const int i = std::min(nx_ - 1, static_cast<int>(u / options_.spacing_m));
  const int j = std::min(ny_ - 1, static_cast<int>(v / options_.spacing_m));
  return static_cast<int64_t>(j) * nx_ + i;
}

void StateLattice::DropMemo() { std::vector<double>().swap(memo_); }

size_t StateLattice::MemoryBytes() const {
  return poses_.capacity() * sizeof(Pose) + valid_.capacity() + memo_.capacity() * sizeof(double);
}

bool StateLattice::NotALoop(const RiskModel& m, const Pose& a, const Pose& b) {
  const ModelParams& mp = m.params();
  const DubinsAirplanePath path(a, b, mp.GroundTurnRadius(), mp.GroundClimbAngle());
  return path.HorizontalLength() <=
         kConnectStretch * std::hypot(b.x - a.x, b.y - a.y) + mp.GroundTurnRadius();
}

std::vector<int32_t> StateLattice::NearStates(const RiskMap& map, const Pose& p) const {
  const double r = options_.connect_radius_m;
  const double sp = options_.spacing_m;
  const int i0 = std::max(0, static_cast<int>(std::floor((p.x - map.x0() - r) / sp - 0.5)));
  const int i1 = std::min(nx_ - 1, static_cast<int>(std::ceil((p.x - map.x0() + r) / sp - 0.5)));
  const int j0 = std::max(0, static_cast<int>(std::floor((p.y - map.y0() - r) / sp - 0.5)));
  const int j1 = std::min(ny_ - 1, static_cast<int>(std::ceil((p.y - map.y0() + r) / sp - 0.5)));
  std::vector<int32_t> out;
  for (int j = j0; j <= j1; ++j) {
    for (int i = i0; i <= i1; ++i) {
      for (int h = 0; h < options_.headings; ++h) {
        for (int l = 0; l < levels_; ++l) {
          const int32_t s = StateOf(i, j, h, l);
          if (!valid_[s]) continue;
          if (std::hypot(poses_[s].x - p.x, poses_[s].y - p.y) > r) continue;
          out.push_back(s);
        }
      }
    }
  }
  return out;
}

absl::Status StateLattice::PriceEdges(const RiskModel& m, std::vector<Edge>* edges,
                                      RiskEvaluator* evaluator, LatticeSearchStats* stats) const {
  const ModelParams& mp = m.params();
  const double step = RiskStep(m);
  std::vector<PieceRisk> rules;
  std::vector<Pose> poses;
  std::vector<ConfigurationRisk> risks;
  size_t begin = 0;
  while (begin < edges->size()) {
    // Edges [begin, end) in one batch (at least one edge, however long).
    rules.clear();
    poses.clear();
    size_t end = begin;
    while (end < edges->size()) {
      Edge& e = (*edges)[end];
      PieceRisk rule(
          TrajectoryPiece::Manoeuvre(e.from, e.to, mp.GroundTurnRadius(), mp.GroundClimbAngle()),
          step, mp);
      if (rule.parts() > kMaxEdgeParts) {
        e.risk = kInf;
        rules.push_back(std::move(rule));
        ++end;
        continue;
      }
      if (end > begin && poses.size() + rule.parts() > kBatchPoses) break;
      rule.AppendMidpoints(0, rule.parts(), &poses);
      rules.push_back(std::move(rule));
      ++end;
    }
    risks.resize(poses.size());
    if (!poses.empty()) {
      if (absl::Status s = evaluator->EvaluateBatch(m, poses, risks); !s.ok()) return s;
    }
    size_t at = 0;
    for (size_t e = begin; e < end; ++e) {
      PieceRisk& rule = rules[e - begin];
      Edge& edge = (*edges)[e];
      if (rule.parts() > kMaxEdgeParts) continue;
      // The piece's own start and end (spec section 6), as EvaluateTrajectory
      // checks them: the manoeuvre's pose at arc 0 and at its length, which
      // may differ from the waypoints in the last bits.
      bool admissible =
          m.CheckConfiguration(rule.AdmissibilitySample(0)) == ViolationKind::kNone &&
          m.CheckConfiguration(rule.AdmissibilitySample(rule.admissibility_samples() - 1)) ==
              ViolationKind::kNone;
      for (int64_t k = 0; k < rule.parts(); ++k, ++at) {
        if (admissible && m.CheckConfiguration(poses[at], risks[at]) != ViolationKind::kNone) {
          admissible = false;
        }
        if (admissible) rule.Add(risks[at], poses[at]);
      }
      edge.risk = admissible ? rule.Risk() : kInf;
      if (stats != nullptr) ++stats->edges_evaluated;
    }
    if (stats != nullptr) stats->configurations += poses.size();
    begin = end;
  }
  return absl::OkStatus();
}

absl::Status StateLattice::Search(const Pose& goal,
                                  const std::vector<std::pair<int32_t, double>>& start_edges,
                                  double* bound, int32_t* best_first, LatticeField* field,
                                  RiskEvaluator* evaluator, const StopCondition& stop,
                                  LatticeSearchStats* stats) {
  const int64_t n = state_count();
  const int H = options_.headings;
  field->goal = goal;
  field->cost.assign(n, kInf);
  field->next.assign(n, LatticeField::kNone);
  std::vector<double> start_risk;
  if (!start_edges.empty()) {
    start_risk.assign(n, kInf);
    for (const auto& [s, r] : start_edges) start_risk[s] = r;
  }
  const size_t per_state = max_into_ * levels_;
  if (memo_.empty()) memo_.assign(n * per_state, std::numeric_limits<double>::quiet_NaN());

  using Item = std::pair<double, int32_t>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
  {
    std::vector<Edge> to_goal;
    std::vector<int32_t> from;
    for (int32_t s : NearStates(model_->map(), goal)) {
      if (!NotALoop(*model_, poses_[s], goal)) continue;
      to_goal.push_back(Edge{poses_[s], goal, kInf});
      from.push_back(s);
    }
    if (absl::Status st = PriceEdges(*model_, &to_goal, evaluator, stats); !st.ok()) return st;
    for (size_t e = 0; e < to_goal.size(); ++e) {
      if (to_goal[e].risk < field->cost[from[e]]) {
        field->cost[from[e]] = to_goal[e].risk;
        field->next[from[e]] = LatticeField::kToGoal;
        queue.push({to_goal[e].risk, from[e]});
      }
    }
  }
  std::vector<uint8_t> settled(n, 0);
  std::vector<Edge> batch;
  std::vector<std::pair<int32_t, size_t>> batch_slots;  // predecessor state, memo slot
  int64_t pops = 0;
  while (!queue.empty()) {
    const auto [c, s] = queue.top();
    queue.pop();
    if (settled[s] || c > field->cost[s]) continue;
    if (c >= *bound) break;
    // Every 16 settled states: each may price dozens of edges, a batch or
    // more of the evaluator's (a slow one too: an FPGA shim).
    if ((++pops & 15) == 0 && stop.Reached()) return absl::CancelledError("lattice search stopped");
    settled[s] = 1;
    if (stats != nullptr) ++stats->states_settled;
    if (!start_risk.empty() && start_risk[s] + c < *bound) {
      *bound = start_risk[s] + c;
      *best_first = s;
    }
    const int l1 = s % levels_;
    const int h1 = (s / levels_) % H;
    const int cell = s / (levels_ * H);
    const int i = cell % nx_;
    const int j = cell / nx_;
    (void)l1;
    // The predecessors' edges not yet priced, in one batch.
    batch.clear();
    batch_slots.clear();
    const std::vector<Primitive>& prims = into_[h1];
    const size_t base = static_cast<size_t>(s) * per_state;
    for (size_t k = 0; k < prims.size(); ++k) {
      const int pi = i - prims[k].di;
      const int pj = j - prims[k].dj;
      if (pi < 0 || pj < 0 || pi >= nx_ || pj >= ny_) continue;
      for (int l0 = 0; l0 < levels_; ++l0) {
        const int32_t p = StateOf(pi, pj, prims[k].from_heading, l0);
        if (!valid_[p] || settled[p]) continue;
        const size_t slot = base + k * levels_ + l0;
        if (std::isnan(memo_[slot])) {
          batch.push_back(Edge{poses_[p], poses_[s], kInf});
          batch_slots.push_back({p, slot});
        }
      }
    }
    if (absl::Status st = PriceEdges(*model_, &batch, evaluator, stats); !st.ok()) return st;
    for (size_t e = 0; e < batch.size(); ++e) memo_[batch_slots[e].second] = batch[e].risk;
    for (size_t k = 0; k < prims.size(); ++k) {
      const int pi = i - prims[k].di;
      const int pj = j - prims[k].dj;
      if (pi < 0 || pj < 0 || pi >= nx_ || pj >= ny_) continue;
      for (int l0 = 0; l0 < levels_; ++l0) {
        const int32_t p = StateOf(pi, pj, prims[k].from_heading, l0);
        if (!valid_[p] || settled[p]) continue;
        const double r = memo_[base + k * levels_ + l0];
        const double nc = c + r;
        if (nc < field->cost[p]) {
          field->cost[p] = nc;
          field->next[p] = s;
          queue.push({nc, p});
        }
      }
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<LatticeRoute> StateLattice::Trace(const RiskModel& m, const Pose& start,
                                                 const LatticeField& field, int32_t first,
                                                 RiskEvaluator* evaluator) const {
  LatticeRoute route;
  route.waypoints.push_back(start);
  for (int32_t s = first; s != LatticeField::kToGoal; s = field.next[s]) {
    if (s < 0 || route.waypoints.size() > poses_.size()) {
      return absl::InternalError("lattice field has a broken chain of next states");
    }
    route.waypoints.push_back(poses_[s]);
  }
  route.waypoints.push_back(field.goal);
  std::vector<Edge> edges;
  for (size_t k = 0; k + 1 < route.waypoints.size(); ++k) {
    edges.push_back(Edge{route.waypoints[k], route.waypoints[k + 1], kInf});
  }
  if (absl::Status s = PriceEdges(m, &edges, evaluator, nullptr); !s.ok()) return s;
  const ModelParams& mp = m.params();
  for (const Edge& e : edges) {
    if (!std::isfinite(e.risk))
      return absl::InternalError("lattice route has an inadmissible edge");
    route.risk += e.risk;
    route.length_m +=
        DubinsAirplanePath(e.from, e.to, mp.GroundTurnRadius(), mp.GroundClimbAngle()).Length();
  }
  return route;
}

absl::StatusOr<std::optional<LatticeRoute>> StateLattice::Solve(const Pose& start, const Pose& goal,
                                                                RiskEvaluator* evaluator,
                                                                const StopCondition& stop,
                                                                LatticeSearchStats* stats) {
  // The start's connections and the direct edge.
  std::vector<Edge> out;
  std::vector<int32_t> to;
  const RiskModel& m = *model_;
  for (int32_t s : NearStates(m.map(), start)) {
    if (!NotALoop(m, start, poses_[s])) continue;
    out.push_back(Edge{start, poses_[s], kInf});
    to.push_back(s);
  }
  const bool direct = std::hypot(goal.x - start.x, goal.y - start.y) <= options_.connect_radius_m &&
                      NotALoop(m, start, goal);
  if (direct) out.push_back(Edge{start, goal, kInf});
  if (absl::Status s = PriceEdges(m, &out, evaluator, stats); !s.ok()) return s;
  std::vector<std::pair<int32_t, double>> start_edges;
  for (size_t e = 0; e < to.size(); ++e) {
    if (std::isfinite(out[e].risk)) start_edges.push_back({to[e], out[e].risk});
  }
  double bound = direct ? out.back().risk : kInf;
  int32_t first = direct && std::isfinite(bound) ? LatticeField::kToGoal : LatticeField::kNone;
  LatticeField field;
  if (!start_edges.empty() || std::isfinite(bound)) {
    if (absl::Status s = Search(goal, start_edges, &bound, &first, &field, evaluator, stop, stats);
        !s.ok()) {
      return s;
    }
  } else {
    field.goal = goal;
  }
  if (first == LatticeField::kNone) return std::optional<LatticeRoute>();
  absl::StatusOr<LatticeRoute> route = Trace(m, start, field, first, evaluator);
  if (!route.ok()) return route.status();
  return std::optional<LatticeRoute>(std::move(*route));
}

absl::StatusOr<LatticeField> StateLattice::Field(const Pose& goal, RiskEvaluator* evaluator,
                                                 const StopCondition& stop,
                                                 LatticeSearchStats* stats) {
  LatticeField field;
  double bound = kInf;
  int32_t first = LatticeField::kNone;
  if (absl::Status s = Search(goal, {}, &bound, &first, &field, evaluator, stop, stats); !s.ok()) {
    return s;
  }
  return field;
}

absl::StatusOr<std::optional<LatticeRoute>> StateLattice::RouteDown(
    const RiskModel& m, const LatticeField& field, const Pose& start,
    RiskEvaluator* evaluator) const {
  std::vector<Edge> out;
  std::vector<int32_t> to;
  for (int32_t s : NearStates(m.map(), start)) {
    if (!std::isfinite(field.cost[s]) || !NotALoop(m, start, poses_[s])) continue;
    out.push_back(Edge{start, poses_[s], kInf});
    to.push_back(s);
  }
  const Pose& goal = field.goal;
  const bool direct = std::hypot(goal.x - start.x, goal.y - start.y) <= options_.connect_radius_m &&
                      NotALoop(m, start, goal);
  if (direct) out.push_back(Edge{start, goal, kInf});
  if (absl::Status s = PriceEdges(m, &out, evaluator, nullptr); !s.ok()) return s;
  double best = direct ? out.back().risk : kInf;
  int32_t first = direct && std::isfinite(best) ? LatticeField::kToGoal : LatticeField::kNone;
  for (size_t e = 0; e < to.size(); ++e) {
    const double c = out[e].risk + field.cost[to[e]];
    if (c < best) {
      best = c;
      first = to[e];
    }
  }
  if (first == LatticeField::kNone) return std::optional<LatticeRoute>();
  absl::StatusOr<LatticeRoute> route = Trace(m, start, field, first, evaluator);
  if (!route.ok()) return route.status();
  return std::optional<LatticeRoute>(std::move(*route));
}

}  // namespace riskplan
