// riskplan-bench-seeds: the kernels of the seeds' planners against the
// figures of the seed papers (docs/benchmarks.md, "Seed planners"):
// - two-tier feasibility (seed 001): paths checked per second and cells
//   compared per microsecond (seed 001: about 100 cells/us, a 161-cell path in
//   1.4 us on a Virtex-5 at 125 MHz);
// - harmonic relaxation (seed 002): time per sweep on a 50 x 50 grid (seed
//   002: 100 us per iteration on a 2 GHz Pentium 4, 27 cycles at 140 MHz on
//   the FPGA) and on demo-city's 1600 x 1600 grid, and sweeps to convergence;
// - RRT (seed 004): vertices added per second with 8 and with 10,000
//   obstacle points, and the clearance test alone, indexed and brute force;
// - GENETIC (seed 003): time per generation and the generation of the last
//   improvement in 1000 generations (seed 003: 85-147 generations, 25-44 ms at
//   74 MHz), free and fixed elevation, on a long and a short demo-city route.
#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "bench/planner_runs.h"
#include "bench/scenarios.h"
#include "benchmark/benchmark.h"
#include "core/base/random.h"
#include "core/map/demo_city.h"
#include "core/planners/harmonic_potential.h"
#include "core/planners/obstacle_points.h"
#include "core/planners/planner.h"
#include "core/planners/planner_support.h"
#include "core/planners/two_tier_feasibility.h"
#include "core/risk/risk_model.h"

namespace riskplan {
namespace {

std::shared_ptr<const RiskModel> DemoCity() {
  static std::shared_ptr<const RiskModel> model = [] {
    auto map = MakeDemoCity();
    return *RiskModel::Create(*map, ModelParams{});
  }();
  return model;
}

// A flat, empty 8 km x 8 km map at 10 m cells.
std::shared_ptr<const RiskModel> FlatMap() {
  static std::shared_ptr<const RiskModel> model = [] {
    MapHeader header;
    header.name = "flat";
    header.res = 10.0;
    header.nx = header.ny = 800;
    MapLayers layers;
    const size_t n = 800 * 800;
    layers.density.assign(n, 1e-3f);
    layers.shelter.assign(n, 5.0f);
    layers.terrain.assign(n, 100.0f);
    layers.nofly.assign(n, 0);
    auto map = RiskMap::Create(header, layers);
    return *RiskModel::Create(*map, ModelParams{});
  }();
  return model;
}

// ---------------------------------------------------------------------------
// Two-tier feasibility.

// GA-like paths: start, four random points, goal, 400 m AMSL (above every
// hill, so that the terrain rule traverses every cell).
std::vector<std::vector<Point3>> GaPaths(size_t n) {
  Rng rng(3);
  std::vector<std::vector<Point3>> out(n);
  for (auto& path : out) {
    for (int k = 0; k < 6; ++k)
      path.push_back({rng.Uniform() * 7999.0, rng.Uniform() * 7999.0, 400.0});
  }
  return out;
}

void BM_TwoTier_GaPaths(benchmark::State& state) {
  const TwoTierOptions options{static_cast<CollisionRule>(state.range(0)), 2, 16,
                               static_cast<CellTraversal>(state.range(1))};
  const TwoTierFeasibility checker(*DemoCity(), options);
  static const auto paths = GaPaths(1000);
  int64_t cells = 0;
  int64_t feasible = 0;
  for (auto _ : state) {
    for (const auto& path : paths) {
      const FeasibilityResult r = checker.CheckPath(path);
      cells += r.cells_checked;
      feasible += r.feasible;
    }
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(paths.size()));
  state.counters["cells_per_us"] =
      benchmark::Counter(static_cast<double>(cells) * 1e-6, benchmark::Counter::kIsRate);
  state.counters["cells_per_path"] =
      static_cast<double>(cells) / (state.iterations() * static_cast<double>(paths.size()));
  state.counters["feasible_share"] =
      static_cast<double>(feasible) / (state.iterations() * static_cast<double>(paths.size()));
}
BENCHMARK(BM_TwoTier_GaPaths)
    ->ArgNames({"band_rule", "bresenham"})
    ->Args({0, 0})
    ->Args({0, 1})
    ->Args({1, 0})
    ->Unit(benchmark::kMicrosecond);

// Seed 001's test trajectory in cells: 55 and 100 detailed cells, then 6
// coarse ones (161 in all), at 400 m over demo-city's terrain.
void BM_TwoTier_SeedTrajectory(benchmark::State& state) {
  const TwoTierOptions options{CollisionRule::kTerrain, 2, 16,
                               static_cast<CellTraversal>(state.range(0))};
  const TwoTierFeasibility checker(*DemoCity(), options);
  const std::vector<Point3> path = {{1002.5, 1002.5, 400.0},
                                    {1002.5 + 54 * 5.0, 1002.5, 400.0},
                                    {1002.5 + 54 * 5.0, 1002.5 + 99 * 5.0, 400.0},
                                    {1002.5 + 54 * 5.0 + 5 * 80.0, 1002.5 + 99 * 5.0, 400.0}};
  int64_t cells = 0;
  for (auto _ : state) {
    const FeasibilityResult r = checker.CheckPath(path);
    benchmark::DoNotOptimize(r.feasible);
    cells += r.cells_checked;
  }
  state.counters["cells_per_path"] = static_cast<double>(cells) / state.iterations();
  state.counters["cells_per_us"] =
      benchmark::Counter(static_cast<double>(cells) * 1e-6, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_TwoTier_SeedTrajectory)->ArgName("bresenham")->Arg(0)->Arg(1);

// ---------------------------------------------------------------------------
// Harmonic relaxation.

// A 50 x 50 grid with two walls and the goal in a corner.
HarmonicPotential Grid50() {
  HarmonicPotential p(50, 50);
  for (int j = 0; j < 35; ++j) p.SetObstacle(15, j);
  for (int j = 15; j < 50; ++j) p.SetObstacle(33, j);
  p.SetGoal(45, 5);
  return p;
}

// demo-city's flyable cells, grouped factor x factor, goal near the centre.
HarmonicPotential DemoCityGrid(int factor) {
  const RiskModel& model = *DemoCity();
  const std::vector<uint8_t> flyable = FlyableCells(model, 0.0);
  const int n = (model.map().nx() + factor - 1) / factor;
  HarmonicPotential p(n, n);
  for (int j = 0; j < model.map().ny(); ++j) {
    for (int i = 0; i < model.map().nx(); ++i) {
      if (flyable[model.map().Index(i, j)] == 0) p.SetObstacle(i / factor, j / factor);
    }
  }
  p.SetGoal(n * 3 / 4, n / 2);
  return p;
}

void BM_HarmonicSweep(benchmark::State& state) {
  HarmonicPotential p = state.range(0) == 50 ? Grid50() : DemoCityGrid(state.range(1));
  const double omega = HarmonicPotential::OptimalOmega(p.nx(), p.ny());
  for (auto _ : state) benchmark::DoNotOptimize(p.Sweep(omega, 1e-6));
  state.counters["cells"] = static_cast<double>(p.nx()) * p.ny();
  state.counters["ns_per_cell"] = benchmark::Counter(
      static_cast<double>(p.nx()) * p.ny() * 1e-9,
      benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_HarmonicSweep)
    ->ArgNames({"grid", "factor"})
    ->Args({50, 0})
    ->Args({1600, 4})
    ->Args({1600, 1})
    ->Unit(benchmark::kMicrosecond);

// Sweeps from v = 0 until converged at the planner's default tolerance, with
// Jacobi-like Gauss-Seidel (omega 1) and with the optimal SOR factor.
void BM_HarmonicConverge(benchmark::State& state) {
  const bool sor = state.range(2) != 0;
  int64_t sweeps = 0;
  for (auto _ : state) {
    state.PauseTiming();
    HarmonicPotential p = state.range(0) == 50 ? Grid50() : DemoCityGrid(state.range(1));
    const double omega = sor ? HarmonicPotential::OptimalOmega(p.nx(), p.ny()) : 1.0;
    state.ResumeTiming();
    sweeps = 0;
    while (!p.Sweep(omega, 1e-6)) ++sweeps;
    ++sweeps;
  }
  state.counters["sweeps"] = static_cast<double>(sweeps);
}
BENCHMARK(BM_HarmonicConverge)
    ->ArgNames({"grid", "factor", "sor"})
    ->Args({50, 0, 0})
    ->Args({50, 0, 1})
    ->Args({1600, 4, 1})
    ->Args({1600, 1, 1})
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);

// ---------------------------------------------------------------------------
// RRT.

// `n` obstacle points on the flat map: 8 on a ring of radius 25 m around the
// goal (closer together than twice the 20 m clearance, so that no edge ever
// reaches the goal and the tree grows for the whole budget), the others
// uniform, away from the start and the goal.
std::vector<Point2> RrtObstacles(size_t n, const Point2& start, const Point2& goal) {
  std::vector<Point2> out;
  for (int k = 0; k < 8; ++k) {
    const double a = k * 2.0 * 3.14159265358979 / 8;
    out.push_back({goal.x + 25.0 * std::cos(a), goal.y + 25.0 * std::sin(a)});
  }
  Rng rng(5);
  while (out.size() < n) {
    const Point2 p{rng.Uniform() * 8000.0, rng.Uniform() * 8000.0};
    if (std::hypot(p.x - start.x, p.y - start.y) > 30.0 &&
        std::hypot(p.x - goal.x, p.y - goal.y) > 30.0) {
      out.push_back(p);
    }
  }
  return out;
}

void BM_RrtPoints(benchmark::State& state) {
  const auto model = FlatMap();
  const Pose start{1000.0, 1000.0, 190.0, 0.0};
  const Pose goal{7000.0, 7000.0, 190.0, 0.0};
  PlanOptions options;
  options.budget.max_time_s = 0.0;
  options.budget.max_iterations = 20000;
  options.params = {{"step_m", 50.0}, {"clearance_m", 20.0}, {"keep_growing", 1.0}};
  options.obstacle_points =
      RrtObstacles(static_cast<size_t>(state.range(0)), {start.x, start.y}, {goal.x, goal.y});
  int64_t vertices = 0;
  for (auto _ : state) {
    auto planner = MakePlanner(PlannerAlgorithm::kRrt);
    CancellationToken cancel;
    auto result = (*planner)->Plan({model, start, goal}, options, cancel, nullptr);
    if (!result.ok()) state.SkipWithError("plan failed");
    vertices += result->tree_size;
  }
  state.counters["points_per_s"] =
      benchmark::Counter(static_cast<double>(vertices), benchmark::Counter::kIsRate);
  state.counters["vertices"] = static_cast<double>(vertices) / state.iterations();
}
BENCHMARK(BM_RrtPoints)->ArgName("obstacles")->Arg(8)->Arg(10000)->Unit(benchmark::kMillisecond);

// The clearance test of one 50 m edge against n points (20 m clearance).
void BM_SegmentClear(benchmark::State& state) {
  const auto points = RrtObstacles(static_cast<size_t>(state.range(0)), {0, 0}, {1000, 1000});
  const ObstaclePointSet set(points, 40.0);
  const bool brute = state.range(1) != 0;
  Rng rng(7);
  std::vector<std::pair<Point2, Point2>> edges;
  for (int k = 0; k < 1024; ++k) {
    const Point2 a{rng.Uniform() * 8000.0, rng.Uniform() * 8000.0};
    const double t = rng.Uniform() * 6.283185307179586;
    edges.push_back({a, {a.x + 50.0 * std::cos(t), a.y + 50.0 * std::sin(t)}});
  }
  size_t k = 0;
  for (auto _ : state) {
    const auto& [a, b] = edges[k++ & 1023];
    benchmark::DoNotOptimize(brute ? set.SegmentClearBruteForce(a, b, 20.0)
                                   : set.SegmentClear(a, b, 20.0));
  }
}
BENCHMARK(BM_SegmentClear)
    ->ArgNames({"obstacles", "brute_force"})
    ->Args({8, 0})
    ->Args({8, 1})
    ->Args({10000, 0})
    ->Args({10000, 1});

// ---------------------------------------------------------------------------
// GENETIC.

// Thread CPU time (bench::ThreadCpuSeconds): the machine is shared, and wall
// time would count the other processes' share.
using bench::ThreadCpuSeconds;

// 1000 generations on a demo-city scenario, seeds 1 to 3; reports the medians
// of: CPU ms per generation, the generation of the last improvement (of the
// fitness: the stream follows it), and the first generation from which the
// streamed trajectories stay within 1 % of the final one's risk (length with
// distance_only, where the fitness is the length).
void BM_GeneticConvergence(benchmark::State& state) {
  const auto model = DemoCity();
  const auto scenarios = bench::DemoCityScenarios(*model);
  const char* name = state.range(0) == 0 ? "5km-a" : "short-climb";
  const bench::Scenario* sc = nullptr;
  for (const auto& s : scenarios) {
    if (std::string(s.name) == name) sc = &s;
  }
  PlanOptions options;
  options.budget.max_time_s = 0.0;
  options.budget.max_iterations = 1000;
  options.params = {{"elevation_mode", static_cast<double>(state.range(1))}};
  // Seed 003's fitness has no risk term: risk_weight 0 is the closest.
  const bool distance_only = state.range(2) != 0;
  if (distance_only) options.params["risk_weight"] = 0.0;
  std::vector<double> last, settled, ms;
  for (auto _ : state) {
    for (uint64_t seed = 1; seed <= 3; ++seed) {
      options.seed = seed;
      auto planner = MakePlanner(PlannerAlgorithm::kGenetic);
      CancellationToken cancel;
      std::vector<PlanImprovement> found;
      const double cpu0 = ThreadCpuSeconds();
      auto result = (*planner)->Plan({model, sc->start, sc->goal}, options, cancel,
                                     [&](const PlanImprovement& i) { found.push_back(i); });
      const double cpu_s = ThreadCpuSeconds() - cpu0;
      if (!result.ok() || found.empty()) {
        state.SkipWithError("no plan");
        return;
      }
      last.push_back(static_cast<double>(found.back().iterations));
      auto value = [&](const PlanImprovement& i) { return distance_only ? i.length_m : i.risk; };
      const double final_value = value(found.back());
      size_t k = found.size() - 1;
      while (k > 0 && std::abs(value(found[k - 1]) - final_value) <= 0.01 * final_value) --k;
      settled.push_back(static_cast<double>(found[k].iterations));
      ms.push_back(1000.0 * cpu_s / static_cast<double>(result->iterations));
    }
  }
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  state.counters["last_improvement_generation"] = median(last);
  state.counters["settled_1pct_generation"] = median(settled);
  state.counters["cpu_ms_per_generation"] = median(ms);
}
BENCHMARK(BM_GeneticConvergence)
    ->ArgNames({"short_route", "fixed_elevation", "distance_only"})
    ->Args({0, 0, 0})
    ->Args({0, 1, 0})
    ->Args({1, 0, 0})
    ->Args({1, 1, 0})
    ->Args({0, 0, 1})
    ->Args({0, 1, 1})
    ->Args({1, 0, 1})
    ->Args({1, 1, 1})
    ->Iterations(1)
    ->Unit(benchmark::kSecond);

}  // namespace
}  // namespace riskplan

BENCHMARK_MAIN();
