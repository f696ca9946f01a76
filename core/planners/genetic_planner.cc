#include "core/planners/genetic_planner.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <unordered_map>

#include "core/base/random.h"
#include "core/planners/obstacle_points.h"
#include "core/planners/path_realizer.h"
#include "core/planners/planner_support.h"
#include "core/planners/two_tier_feasibility.h"

namespace riskplan {
namespace {

// A transitional waypoint. `band_fraction` places its altitude in the band of
// its cell (free-elevation mode; unused in fixed mode).
struct Gene {
  double x = 0.0;
  double y = 0.0;
  double band_fraction = 0.5;
  bool operator==(const Gene&) const = default;
};

struct Fitness {
  int64_t collision_cells = 0;  // two-tier
  int64_t violations = 0;       // exact check of the flown trajectory
  double cost = 0.0;
  bool Feasible() const { return collision_cells == 0 && violations == 0; }
  bool operator<(const Fitness& o) const {
    if (collision_cells != o.collision_cells) return collision_cells < o.collision_cells;
    if (violations != o.violations) return violations < o.violations;
    return cost < o.cost;
  }
};

struct Chromosome {
  std::vector<Gene> genes;
  Fitness fitness;
};

// The manoeuvre between two poses, compared bit for bit. Offspring share most
// of their manoeuvres with their parents (a crossover changes the one at the
// cut, a mutation two), so their length, exact check and risk are remembered.
struct PieceKey {
  Pose a;
  Pose b;
  bool operator==(const PieceKey& o) const { return std::memcmp(this, &o, sizeof(*this)) == 0; }
};
static_assert(sizeof(PieceKey) == 8 * sizeof(double));

struct PieceKeyHash {
  size_t operator()(const PieceKey& k) const {
    const double* d = &k.a.x;
    uint64_t h = 0x9e3779b97f4a7c15ULL;
    for (int i = 0; i < 8; ++i) {
      h ^= std::bit_cast<uint64_t>(d[i]) + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2);
    }
    return static_cast<size_t>(h);
  }
};

struct PieceMemo {
  double length_m = 0.0;
  int violations = 0;
  bool has_risk = false;
  bool pending = false;  // its samples are in the current batch
  double risk = 0.0;     // the piece risk by the fitness's step, once has_risk
};

class Run : private SeedRunBase {
 public:
  Run(const PlanningProblem& problem, const PlanOptions& options, const PlannerParamValues& params,
      RiskEvaluator* evaluator, const CancellationToken& cancel,
      const ImprovementCallback& on_improvement)
      : SeedRunBase(problem, options, evaluator, cancel, on_improvement),
        population_(static_cast<size_t>(params.Get("population"))),
        waypoints_(static_cast<size_t>(params.Get("waypoints"))),
        crossover_share_(params.Get("crossover_share")),
        fixed_mode_(params.Get("elevation_mode") != 0.0),
        fixed_altitude_m_(params.Get("fixed_altitude_m") > 0.0
                              ? params.Get("fixed_altitude_m")
                              : 0.5 * (problem.start.z + problem.goal.z)),
        risk_weight_(params.Get("risk_weight")),
        risk_step_m_(params.Get("risk_step_m")),
        clearance_m_(params.Get("clearance_m")),
        stop_(limits_.Stop()),
        rng_(options.seed),
        feasibility_(model_, TwoTierOptions{CollisionRule::kFlightBand,
                                            static_cast<int>(params.Get("detailed_segments"))}),
        request_points_(options.obstacle_points,
                        std::max({2.0 * clearance_m_, 4.0 * model_.map().res(), 1.0})),
        checker_(model_, &request_points_, clearance_m_) {}

  absl::StatusOr<PlanResult> Execute();

 private:
  double FractionOf(const Pose& pose) const;
  Gene RandomGene();
  Chromosome RandomChromosome();
  std::vector<Pose> Decode(const Chromosome& c) const;
  PieceMemo& Piece(const Pose& a, const Pose& b);
  // Fitness of every chromosome of `pool` from index `first`. RunStopped()
  // when the budget ends or the token is cancelled meanwhile.
  absl::Status Evaluate(std::vector<Chromosome>* pool, size_t first);
  // Evaluates the samples in batch_ and completes the risk of every piece in
  // `pending` (in the order of their samples), then empties both.
  absl::Status FlushBatch(std::vector<std::pair<PieceMemo*, PieceRisk>>* pending);
  void Mutate(int kind, Chromosome* c);
  absl::Status MaybeReport();
  // The generations, until the budget ends (sets result->reason when the
  // token is cancelled); RunStopped() when it ends inside one.
  absl::Status Generations(PlanResult* result);

  // Samples of the fitness's risk evaluated in one batch, at most (plus one
  // piece's).
  static constexpr size_t kMaxBatch = size_t{1} << 16;

  const size_t population_;
  const size_t waypoints_;
  const double crossover_share_;
  const bool fixed_mode_;
  const double fixed_altitude_m_;
  const double risk_weight_;
  const double risk_step_m_;
  const double clearance_m_;
  const StopCondition stop_;  // limits_'s, polled inside a generation
  Rng rng_;
  const TwoTierFeasibility feasibility_;
  const ObstaclePointSet request_points_;
  const TrajectoryChecker checker_;
  double length_ref_m_ = 1.0;
  double risk_ref_ = 1.0;
  std::vector<Chromosome> parents_;
  int64_t generations_ = 0;
  int64_t evaluated_ = 0;
  std::optional<Fitness> best_fitness_;
  std::optional<PlanImprovement> best_;
  std::unordered_map<PieceKey, PieceMemo, PieceKeyHash> pieces_;
  // Scratch.
  std::vector<Pose> batch_;
  std::vector<ConfigurationRisk> risks_;
};

double Run::FractionOf(const Pose& pose) const {
  int i = 0, j = 0;
  double low = 0.0, high = 0.0;
  if (!model_.map().CellOf(pose.x, pose.y, &i, &j) || !CellBand(model_, i, j, &low, &high) ||
      !(high > low)) {
    return 0.5;
  }
  return std::clamp((pose.z - low) / (high - low), 0.0, 1.0);
}

Gene Run::RandomGene() {
  const RiskMap& map = model_.map();
  Gene g;
  g.x = map.x0() + rng_.Uniform() * map.width_m();
  g.y = map.y0() + rng_.Uniform() * map.height_m();
  // In fixed mode the fraction is unused; a constant keeps identical
  // chromosomes identical (premature convergence is detected on the genes).
  g.band_fraction = fixed_mode_ ? 0.5 : rng_.Uniform();
  return g;
}

Chromosome Run::RandomChromosome() {
  Chromosome c;
  for (size_t k = 0; k < waypoints_; ++k) c.genes.push_back(RandomGene());
  return c;
}

std::vector<Pose> Run::Decode(const Chromosome& c) const {
  std::vector<Point2> xy = {{problem_.start.x, problem_.start.y}};
  for (const Gene& g : c.genes) xy.push_back({g.x, g.y});
  xy.push_back({problem_.goal.x, problem_.goal.y});
  std::vector<Pose> poses = {problem_.start};
  for (size_t k = 0; k < c.genes.size(); ++k) {
    const Gene& g = c.genes[k];
    double z = fixed_altitude_m_;
    if (!fixed_mode_) {
      int i = 0, j = 0;
      double low = 0.0, high = 0.0;
      z = 0.5 * (problem_.start.z + problem_.goal.z);  // no band: infeasible anyway
      if (model_.map().CellOf(g.x, g.y, &i, &j) && CellBand(model_, i, j, &low, &high)) {
        z = low + g.band_fraction * (high - low);
      }
    }
    poses.push_back(Pose{g.x, g.y, z, BisectorHeading(xy[k], xy[k + 1], xy[k + 2])});
  }
  poses.push_back(problem_.goal);
  return poses;
}

PieceMemo& Run::Piece(const Pose& a, const Pose& b) {
  auto [it, inserted] = pieces_.try_emplace(PieceKey{a, b});
  PieceMemo& m = it->second;
  if (inserted) {
    const ModelParams& mp = model_.params();
    const TrajectoryPiece piece =
        TrajectoryPiece::Manoeuvre(a, b, mp.GroundTurnRadius(), mp.GroundClimbAngle());
    m.length_m = piece.Length();
    m.violations = checker_.Violations(piece, /*first_only=*/false);
  }
  return m;
}

absl::Status Run::FlushBatch(std::vector<std::pair<PieceMemo*, PieceRisk>>* pending) {
  risks_.resize(batch_.size());
  if (!batch_.empty()) {
    if (absl::Status s = evaluator_->EvaluateBatch(model_, batch_, risks_); !s.ok()) return s;
  }
  size_t cursor = 0;
  for (auto& [m, rule] : *pending) {
    while (!rule.complete()) {
      rule.Add(risks_[cursor], batch_[cursor]);
      ++cursor;
    }
    m->risk = rule.Risk();
    m->pending = false;
    m->has_risk = true;
  }
  pending->clear();
  batch_.clear();
  return absl::OkStatus();
}

absl::Status Run::Evaluate(std::vector<Chromosome>* pool, size_t first) {
  const ModelParams& mp = model_.params();
  // Bounded memory; cleared only here, so references stay valid below.
  if (pieces_.size() > (size_t{1} << 18)) pieces_.clear();
  batch_.clear();
  // The pieces whose samples are in this batch, with their risk rules, in
  // the order of their samples in batch_.
  std::vector<std::pair<PieceMemo*, PieceRisk>> pending;
  std::vector<std::pair<size_t, std::vector<PieceMemo*>>> feasible;
  // A memo abandoned half-way by a stopped run must not keep its pending
  // mark (the run ends, but the memo table is the run's).
  auto stopped = [&]() {
    for (auto& [m, rule] : pending) m->pending = false;
    return RunStopped();
  };
  for (size_t c = first; c < pool->size(); ++c) {
    if (stop_.Reached()) return stopped();
    Chromosome& ch = (*pool)[c];
    const std::vector<Pose> poses = Decode(ch);
    std::vector<Point3> polyline;
    for (const Pose& p : poses) polyline.push_back({p.x, p.y, p.z});
    ch.fitness = Fitness{};
    ch.fitness.collision_cells =
        feasibility_.CheckPath(polyline, /*count_all=*/true).colliding_cells;
    ++evaluated_;
    if (ch.fitness.collision_cells > 0) continue;
    std::vector<PieceMemo*> memos;
    for (size_t k = 0; k + 1 < poses.size(); ++k) {
      // Checking a piece is up to --max_edge_samples configurations.
      if (k > 0 && stop_.Reached()) return stopped();
      PieceMemo& m = Piece(poses[k], poses[k + 1]);
      ch.fitness.violations += m.violations;
      memos.push_back(&m);
    }
    if (ch.fitness.violations > 0) continue;
    for (size_t k = 0; k < memos.size(); ++k) {
      PieceMemo& m = *memos[k];
      if (m.has_risk || m.pending) continue;
      // The piece-risk rule of spec section 4 with the fitness's step.
      PieceRisk rule(
          TrajectoryPiece::Manoeuvre(poses[k], poses[k + 1], mp.GroundTurnRadius(), mp.GroundClimbAngle()),
          risk_step_m_, mp);
      // A batch is evaluated once it holds kMaxBatch samples (it holds
      // every piece's whole samples, so it may hold one piece more): the
      // same risks, in bounded memory, however many long pieces a
      // generation has.
      if (batch_.size() >= kMaxBatch) {
        if (stop_.Reached()) return stopped();
        if (absl::Status s = FlushBatch(&pending); !s.ok()) return s;
      }
      rule.AppendMidpoints(0, rule.parts(), &batch_);
      m.pending = true;
      pending.emplace_back(&m, std::move(rule));
    }
    feasible.push_back({c, std::move(memos)});
  }
  if (stop_.Reached()) return stopped();
  if (absl::Status s = FlushBatch(&pending); !s.ok()) return s;
  for (auto& [c, memos] : feasible) {
    double risk = 0.0;
    double length = 0.0;
    for (PieceMemo* m : memos) {
      risk += m->risk;
      length += m->length_m;
    }
    (*pool)[c].fitness.cost =
        (1.0 - risk_weight_) * length / length_ref_m_ + risk_weight_ * risk / risk_ref_;
  }
  return absl::OkStatus();
}

void Run::Mutate(int kind, Chromosome* c) {
  const size_t n = c->genes.size();
  const size_t k = rng_.Below(n);
  const Gene prev = k == 0 ? Gene{problem_.start.x, problem_.start.y, FractionOf(problem_.start)}
                           : c->genes[k - 1];
  const Gene next = k + 1 == n ? Gene{problem_.goal.x, problem_.goal.y, FractionOf(problem_.goal)}
                               : c->genes[k + 1];
  auto between = [&](double a, double b) { return a + rng_.Uniform() * (b - a); };
  switch (kind) {
    case 0:  // global perturb: anywhere on the map
      c->genes[k] = RandomGene();
      break;
    case 1:  // local perturb: inside the box of the neighbours
      c->genes[k] = Gene{between(prev.x, next.x), between(prev.y, next.y),
                         between(prev.band_fraction, next.band_fraction)};
      break;
    case 2:  // delete: the waypoint moves to the midpoint of its neighbours
      c->genes[k] = Gene{0.5 * (prev.x + next.x), 0.5 * (prev.y + next.y),
                         0.5 * (prev.band_fraction + next.band_fraction)};
      break;
    default: {  // swap two waypoints
      const size_t other = rng_.Below(n);
      std::swap(c->genes[k], c->genes[other]);
      break;
    }
  }
  if (fixed_mode_) c->genes[k].band_fraction = 0.5;
}

absl::Status Run::MaybeReport() {
  const Chromosome& best = parents_.front();
  if (!best.fitness.Feasible()) return absl::OkStatus();
  if (best_fitness_.has_value() && !(best.fitness < *best_fitness_)) return absl::OkStatus();
  best_fitness_ = best.fitness;
  auto improvement = EvaluateWaypoints(model_, Decode(best), evaluator_, stop_);
  if (!improvement.ok()) return improvement.status();
  // The fitness's exact stage checks the very samples EvaluateTrajectory does.
  if (!improvement->has_value()) return absl::OkStatus();
  PlanImprovement& found = **improvement;
  found.iterations = generations_;
  found.tree_size = evaluated_;
  found.elapsed_s = limits_.Elapsed();
  best_ = found;
  if (on_improvement_) on_improvement_(found);
  return absl::OkStatus();
}

absl::StatusOr<PlanResult> Run::Execute() {
  const ModelParams& mp = model_.params();
  const Pose& s = problem_.start;
  const Pose& g = problem_.goal;
  length_ref_m_ = std::max(
      std::sqrt((g.x - s.x) * (g.x - s.x) + (g.y - s.y) * (g.y - s.y) + (g.z - s.z) * (g.z - s.z)),
      mp.GroundTurnRadius());
  {
    // R_ref: the straight segment's risk, sampled like the fitness's.
    PieceRisk line(TrajectoryPiece::Segment({s.x, s.y, s.z}, {g.x, g.y, g.z}), risk_step_m_, mp);
    std::vector<Pose> samples;
    line.AppendMidpoints(0, line.parts(), &samples);
    std::vector<ConfigurationRisk> risks(samples.size());
    if (!samples.empty()) {
      if (absl::Status st = evaluator_->EvaluateBatch(model_, samples, risks); !st.ok()) return st;
    }
    for (size_t k = 0; k < risks.size(); ++k) line.Add(risks[k], samples[k]);
    // A floor of 1e-12 per metre keeps the weight finite on an empty map.
    // (lambda / gs of the line's track: lambda / v in still air.)
    const double per_metre =
        mp.failure_rate_per_s / model_.wind().GroundSpeed(std::atan2(g.y - s.y, g.x - s.x));
    risk_ref_ = std::max(line.Risk(), per_metre * length_ref_m_ * 1e-12);
    if (!(risk_ref_ > 0.0)) risk_ref_ = 1.0;  // lambda = 0: no risk anywhere
  }

  PlanResult result;
  result.reason = StopReason::kBudgetExhausted;
  absl::Status step = Generations(&result);
  if (!step.ok()) {
    if (!IsRunStopped(step)) return step;
    if (limits_.Cancelled()) result.reason = StopReason::kCancelled;
  }
  if (!best_.has_value() && result.reason != StopReason::kCancelled) {
    result.reason = StopReason::kNoSolution;
  }
  result.best = best_;
  result.iterations = generations_;
  result.tree_size = evaluated_;
  result.elapsed_s = limits_.Elapsed();
  result.configurations_evaluated = evaluator_->evaluated();
  return result;
}

absl::Status Run::Generations(PlanResult* result) {
  for (size_t c = 0; c < population_; ++c) parents_.push_back(RandomChromosome());
  if (absl::Status st = Evaluate(&parents_, 0); !st.ok()) return st;
  std::stable_sort(parents_.begin(), parents_.end(),
                   [](const Chromosome& a, const Chromosome& b) { return a.fitness < b.fitness; });
  if (absl::Status st = MaybeReport(); !st.ok()) return st;

  const size_t crossovers = 2 * static_cast<size_t>(std::floor(population_ * crossover_share_ / 2));
  std::vector<Chromosome> pool;
  while (true) {
    if (limits_.Cancelled()) {
      result->reason = StopReason::kCancelled;
      break;
    }
    if (limits_.OutOfIterations(generations_) || limits_.OutOfTime()) break;
    ++generations_;
    // Selection: binary tournaments.
    std::vector<size_t> winners(population_);
    for (size_t& w : winners) {
      const size_t a = rng_.Below(population_);
      const size_t b = rng_.Below(population_);
      w = parents_[b].fitness < parents_[a].fitness ? b : a;
    }
    // Genetic operations: offspring after the parents in `pool`.
    pool = parents_;
    for (size_t c = 0; c < crossovers; c += 2) {
      Chromosome a = parents_[winners[rng_.Below(population_)]];
      Chromosome b = parents_[winners[rng_.Below(population_)]];
      const size_t cut = waypoints_ > 1 ? 1 + rng_.Below(waypoints_ - 1) : 0;
      for (size_t k = cut; k < waypoints_; ++k) std::swap(a.genes[k], b.genes[k]);
      pool.push_back(std::move(a));
      pool.push_back(std::move(b));
    }
    for (size_t m = 0; pool.size() < 2 * population_; ++m) {
      Chromosome c = parents_[winners[rng_.Below(population_)]];
      Mutate(static_cast<int>(m % 4), &c);
      pool.push_back(std::move(c));
    }
    if (absl::Status st = Evaluate(&pool, population_); !st.ok()) return st;
    // Update: the best of parents and offspring.
    std::stable_sort(pool.begin(), pool.end(), [](const Chromosome& a, const Chromosome& b) {
      return a.fitness < b.fitness;
    });
    pool.resize(population_);
    parents_.swap(pool);
    // Premature convergence: every chromosome the same.
    if (std::all_of(parents_.begin() + 1, parents_.end(),
                    [&](const Chromosome& c) { return c.genes == parents_[0].genes; })) {
      parents_.resize(1);
      for (size_t c = 1; c < population_; ++c) parents_.push_back(RandomChromosome());
      if (absl::Status st = Evaluate(&parents_, 1); !st.ok()) return st;
      std::stable_sort(
          parents_.begin(), parents_.end(),
          [](const Chromosome& a, const Chromosome& b) { return a.fitness < b.fitness; });
    }
    if (absl::Status st = MaybeReport(); !st.ok()) return st;
  }
  return absl::OkStatus();
}

const std::vector<PlannerParamInfo>& ParamInfo() {
  static const auto* info = new std::vector<PlannerParamInfo>{
      {"population", 32, 4, 1024, "chromosomes per generation (seed 003: 32)"},
      {"waypoints", 4, 1, 16, "transitional waypoints per chromosome (seed 003: 4)"},
      {"crossover_share", 0.75, 0.0, 1.0,
       "share of the offspring made by crossover; the rest by the four mutations equally"},
      {"elevation_mode", 0, 0, 1,
       "0: free elevation (altitudes are genes, seed 003's MODE I); 1: fixed (MODE II)"},
      {"fixed_altitude_m", 0.0, 0.0, 20000.0,
       "altitude AMSL of every waypoint in fixed mode (0: the mean of start and goal)"},
      {"risk_weight", 0.8, 0.0, 1.0,
       "weight of risk against length in the cost: (1 - w) L / L_ref + w R / R_ref"},
      {"risk_step_m", 25.0, 1.0, 1000.0, "sampling step of the fitness's risk, m"},
      {"clearance_m", 20.0, 0.0, 1000.0,
       "the trajectory keeps farther than this from every request's obstacle point, m"},
      {"detailed_segments", 2, 0, 17,
       "segments checked on the detailed grid by the two-tier check (seed 001: 2)"},
  };
  return *info;
}

}  // namespace

constinit const AlgorithmEntry kGeneticEntry = {&ParamInfo,
                                                &PlanSeedRun<Run, PlannerAlgorithm::kGenetic>};

}  // namespace riskplan
