// riskplan-bench-shared-tree: missions from scattered starts to one depot on
// demo-city, planned on one shared goal tree (core/planners/shared_goal_tree.h)
// against one separate RISK_RRT_STAR plan per mission (issue 19, part 2).
//
// BM_SeparatePlans runs each mission alone with a 1-s wall-time budget
// (--separate_s) and keeps its final risk. BM_SharedTree then plans all the
// missions on one tree and records, at every improvement, the CPU time of the
// planning thread; it stops when every mission has reached the risk of its
// separate plan (or at --cap_factor x the separate plans' CPU time and
// configurations evaluated, whichever comes later). Both
// report CPU time, not wall time: the machine may be shared, and a loaded
// core stretches wall time but not the work done. Counters of BM_SharedTree:
//   reach_cpu_s     CPU time at which the last mission reached its separate risk
//   reach_ratio     that / the separate plans' total CPU time (target <= 0.25)
//   reached         missions that reached it (of --missions)
//   q_median, q_max each mission's risk at 0.25 x the separate total CPU,
//                   relative to its separate plan's risk (1: equal)
//   reached_quarter, reached_half, reached_1x   missions at or below their
//                   separate risk at 0.25 x, 0.5 x and 1 x the separate total CPU
// The same in configurations evaluated (the risk evaluations both sides made,
// a count of work that does not depend on the machine's load, so two variants
// of the planner compare exactly): c_reached_quarter, c_reached_half,
// c_reached_1x, cq_median, cq_max.
// A per-mission table follows the benchmark output.
//
//   riskplan-bench-shared-tree [--missions=32] [--separate_s=1] [--seed=1]
//                              [--separate_iterations=0] [--shared_params=path_bias=0.5]
//                              [--separate_cache=FILE] [--shared_seed=0]
//                              [--start_area=X,Y,R]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/strings/str_split.h"
#include "bench/planner_runs.h"
#include "bench/scenarios.h"
#include "benchmark/benchmark.h"
#include "core/base/random.h"
#include "core/map/demo_city.h"
#include "core/planners/cost_to_go_field.h"
#include "core/planners/planner.h"
#include "core/planners/shared_goal_tree.h"

ABSL_FLAG(int, missions, 32, "missions, from scattered starts to one depot");
ABSL_FLAG(double, separate_s, 1.0, "wall-time budget of each separate plan, s");
ABSL_FLAG(int64_t, separate_iterations, 0,
          "iteration budget of each separate plan instead of wall time (0: wall time)");
ABSL_FLAG(double, cap_factor, 1.0,
          "the shared tree stops at this many times the separate plans' total CPU time");
ABSL_FLAG(double, wall_net_factor, 4.0,
          "the shared tree's wall-time safety net: this x the CPU cap + 10 s (raise it on a "
          "loaded machine, where a CPU second takes many wall seconds)");
ABSL_FLAG(uint64_t, seed, 1, "seed of every plan");
ABSL_FLAG(uint64_t, shared_seed, 0, "seed of the shared tree alone (0: --seed)");
ABSL_FLAG(std::string, separate_cache, "",
          "file of the separate plans' results: read when it exists (and its plans are not run), "
          "else written after they are; for comparing shared-tree variants against one set");
ABSL_FLAG(std::string, shared_params, "",
          "RISK_RRT_STAR parameters of the shared tree only, name=value,... (the separate plans "
          "keep the defaults)");
ABSL_FLAG(bool, warm_guide_field, false,
          "with guide = 1 in --shared_params: build the depot's guide field before the shared "
          "tree's clock starts, as a server that planned for this depot before has it cached");
ABSL_FLAG(std::string, start_area, "",
          "X,Y,R: draw the starts in the disc of radius R m around (X, Y) instead of over the "
          "whole city (still 2 km from the depot and 200 m from each other)");

namespace riskplan {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

using bench::ThreadCpuSeconds;

const std::shared_ptr<const RiskModel>& Model() {
  static const std::shared_ptr<const RiskModel> model = [] {
    auto map = MakeDemoCity();
    return *RiskModel::Create(*map, ModelParams{});
  }();
  return model;
}

// The depot in the south-east suburbs; starts drawn uniformly over the city
// (fixed generator), or over the disc --start_area, at least 2 km from it and
// 200 m from each other.
struct Fleet {
  Pose depot;
  std::vector<Pose> starts;
};

const Fleet& TheFleet() {
  static const Fleet fleet = [] {
    const RiskModel& model = *Model();
    Fleet f;
    f.depot = *bench::FindFlyablePose(model, 6500, 1500, kPi / 2);
    Rng rng(20261202);
    const double w = model.map().width_m();
    std::vector<double> area;  // X, Y, R, or empty: the whole city
    for (absl::string_view v :
         absl::StrSplit(absl::GetFlag(FLAGS_start_area), ',', absl::SkipEmpty())) {
      area.push_back(std::stod(std::string(v)));
    }
    if (!area.empty() && (area.size() != 3 || !(area[2] > 0.0))) {
      std::fprintf(stderr, "--start_area: want X,Y,R with R > 0\n");
      std::exit(2);
    }
    int64_t draws = 0;
    while (static_cast<int>(f.starts.size()) < absl::GetFlag(FLAGS_missions)) {
      if (++draws > 1000000) {
        std::fprintf(stderr, "cannot place %d starts (--start_area too small?)\n",
                     absl::GetFlag(FLAGS_missions));
        std::exit(2);
      }
      double x = model.map().x0() + 600 + rng.Uniform() * (w - 1200);
      double y = model.map().y0() + 600 + rng.Uniform() * (w - 1200);
      if (!area.empty()) {
        x = area[0] + (2.0 * rng.Uniform() - 1.0) * area[2];
        y = area[1] + (2.0 * rng.Uniform() - 1.0) * area[2];
        if (std::hypot(x - area[0], y - area[1]) > area[2]) continue;
      }
      const double theta = rng.Uniform() * kTwoPi;
      if (std::hypot(x - f.depot.x, y - f.depot.y) < 2000.0) continue;
      std::optional<Pose> p = bench::FindFlyablePose(model, x, y, theta);
      if (!p.has_value()) continue;
      bool crowded = false;
      for (const Pose& s : f.starts) crowded |= std::hypot(s.x - p->x, s.y - p->y) < 200.0;
      if (!crowded) f.starts.push_back(*p);
    }
    return f;
  }();
  return fleet;
}

struct Separate {
  double risk = kInf;
  double cpu_s = 0.0;
  int64_t iterations = 0;
  uint64_t configs = 0;  // configurations evaluated
};
std::vector<Separate>& SeparateResults() {
  static std::vector<Separate> results;
  return results;
}

// The cache file: one line per mission, risk (as a C99 hex float, exact),
// CPU s, iterations, configurations.
bool ReadSeparateCache(const std::string& path, std::vector<Separate>* out) {
  std::ifstream in(path);
  if (!in) return false;
  std::vector<Separate> read;
  std::string risk;
  Separate s;
  while (in >> risk >> s.cpu_s >> s.iterations >> s.configs) {
    s.risk = std::strtod(risk.c_str(), nullptr);
    read.push_back(s);
  }
  if (read.size() != TheFleet().starts.size()) return false;
  *out = std::move(read);
  return true;
}

void WriteSeparateCache(const std::string& path, const std::vector<Separate>& results) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) return;
  for (const Separate& s : results) {
    std::fprintf(f, "%a %.6f %lld %llu\n", s.risk, s.cpu_s, static_cast<long long>(s.iterations),
                 static_cast<unsigned long long>(s.configs));
  }
  std::fclose(f);
}

void RunSeparate() {
  const Fleet& fleet = TheFleet();
  std::vector<Separate>& out = SeparateResults();
  out.clear();
  const std::string cache = absl::GetFlag(FLAGS_separate_cache);
  if (!cache.empty() && ReadSeparateCache(cache, &out)) return;
  for (const Pose& start : fleet.starts) {
    DirectRiskEvaluator evaluator;
    std::unique_ptr<Planner> planner = *MakePlanner(PlannerAlgorithm::kRiskRrtStar, &evaluator);
    PlanOptions options;
    options.seed = absl::GetFlag(FLAGS_seed);
    const int64_t iterations = absl::GetFlag(FLAGS_separate_iterations);
    options.budget.max_time_s = iterations > 0 ? 0.0 : absl::GetFlag(FLAGS_separate_s);
    options.budget.max_iterations = iterations;
    CancellationToken cancel;
    const double before = ThreadCpuSeconds();
    auto result = planner->Plan({Model(), start, fleet.depot}, options, cancel, nullptr);
    Separate s;
    s.cpu_s = ThreadCpuSeconds() - before;
    s.configs = evaluator.evaluated();
    if (result.ok() && result->best.has_value()) s.risk = result->best->risk;
    if (result.ok()) s.iterations = result->iterations;
    out.push_back(s);
  }
  if (!cache.empty()) WriteSeparateCache(cache, out);
}

void BM_SeparatePlans(benchmark::State& state) {
  for (auto _ : state) RunSeparate();
  double cpu = 0.0;
  int solved = 0;
  for (const Separate& s : SeparateResults()) {
    cpu += s.cpu_s;
    solved += std::isfinite(s.risk) ? 1 : 0;
  }
  state.counters["plans_cpu_s"] = cpu;
  state.counters["solved"] = solved;
}
BENCHMARK(BM_SeparatePlans)->Unit(benchmark::kSecond)->Iterations(1);

struct SharedMission {
  double reach_cpu_s = kInf;      // CPU time when it first reached its separate risk
  double risk_at_quarter = kInf;  // its risk at 0.25 x the separate total CPU
  double final_risk = kInf;
  double reach_configs = kInf;            // configurations evaluated by then
  double risk_at_quarter_configs = kInf;  // its risk at 0.25 x the separate total configurations
};
std::vector<SharedMission>& SharedResults() {
  static std::vector<SharedMission> results;
  return results;
}
int64_t shared_iterations = 0;
int64_t shared_tree_size = 0;

void BM_SharedTree(benchmark::State& state) {
  // Before the timed loop (PauseTiming is only valid inside it): with
  // --benchmark_filter=Shared, or the separate results from --separate_cache.
  if (SeparateResults().empty()) RunSeparate();
  const Fleet& fleet = TheFleet();
  const std::vector<Separate>& separate = SeparateResults();
  double separate_cpu = 0.0;
  double separate_configs = 0.0;
  for (const Separate& s : separate) {
    separate_cpu += s.cpu_s;
    separate_configs += static_cast<double>(s.configs);
  }
  const double quarter = 0.25 * separate_cpu;
  const double quarter_configs = 0.25 * separate_configs;
  const double cap = absl::GetFlag(FLAGS_cap_factor) * separate_cpu;
  std::vector<SharedMission>& missions = SharedResults();
  const std::map<std::string, double> shared_params =
      bench::ParsePlannerParams(absl::GetFlag(FLAGS_shared_params));
  if (absl::GetFlag(FLAGS_warm_guide_field) && shared_params.count("guide") > 0 &&
      shared_params.at("guide") >= 1.0) {
    DirectRiskEvaluator evaluator;
    const double cpu0 = ThreadCpuSeconds();
    auto field = GuideFieldCache::Default().Get(
        *Model(), fleet.depot, bench::GuideFieldOptions(shared_params), &evaluator);
    if (!field.ok()) {
      state.SkipWithError(std::string(field.status().message()).c_str());
      return;
    }
    std::printf("guide field of the depot, built before the shared tree: %.2f CPU s, %.2f MB\n",
                ThreadCpuSeconds() - cpu0, (*field)->MemoryBytes() / 1e6);
  }
  double cpu_used = 0.0;
  double configs_used = 0.0;
  for (auto _ : state) {
    missions.assign(fleet.starts.size(), SharedMission{});
    SharedTreeProblem problem;
    problem.model = Model();
    problem.goal = fleet.depot;
    for (const Pose& start : fleet.starts) {
      SharedTreeMission m;
      m.start = start;
      // A wall-time safety net well past the CPU cap (the callback cancels).
      m.budget.max_time_s = absl::GetFlag(FLAGS_wall_net_factor) * cap + 10.0;
      m.budget.max_iterations = 0;
      problem.missions.push_back(m);
    }
    SharedTreeOptions options;
    options.seed = absl::GetFlag(FLAGS_shared_seed) != 0 ? absl::GetFlag(FLAGS_shared_seed)
                                                         : absl::GetFlag(FLAGS_seed);
    options.params = shared_params;
    CancellationToken cancel;
    size_t reached = 0;
    const double before = ThreadCpuSeconds();
    DirectRiskEvaluator evaluator;  // what the planner would make itself, counted here
    SharedGoalTreePlanner planner(&evaluator);
    auto results = planner.Plan(
        problem, options, cancel,
        [&](size_t m, const PlanImprovement& i) {
          const double cpu = ThreadCpuSeconds() - before;
          const double configs = static_cast<double>(evaluator.evaluated());
          SharedMission& sm = missions[m];
          sm.final_risk = i.risk;
          if (cpu <= quarter) sm.risk_at_quarter = i.risk;
          if (configs <= quarter_configs) sm.risk_at_quarter_configs = i.risk;
          if (!std::isfinite(sm.reach_configs) && i.risk <= separate[m].risk) {
            sm.reach_configs = configs;
          }
          if (!std::isfinite(sm.reach_cpu_s) && i.risk <= separate[m].risk) {
            sm.reach_cpu_s = cpu;
            ++reached;
          }
          shared_iterations = i.iterations;
          shared_tree_size = i.tree_size;
          // Every mission there, or the cap in both CPU and configurations:
          // nothing more to measure.
          const double cap_configs = absl::GetFlag(FLAGS_cap_factor) * separate_configs;
          if (reached == missions.size() || (cpu >= cap && configs >= cap_configs)) {
            cancel.Cancel();
          }
        },
        nullptr);
    cpu_used = ThreadCpuSeconds() - before;
    configs_used = static_cast<double>(evaluator.evaluated());
    if (!results.ok()) state.SkipWithError(std::string(results.status().message()).c_str());
  }
  double reach = 0.0;
  int reached = 0;
  int reached_quarter = 0;
  int reached_half = 0;
  int reached_1x = 0;
  int c_reached[3] = {0, 0, 0};  // by 0.25 x, 0.5 x, 1 x the separate configurations
  std::vector<double> q;
  std::vector<double> cq;
  for (size_t m = 0; m < missions.size(); ++m) {
    const SharedMission& sm = missions[m];
    if (std::isfinite(sm.reach_cpu_s)) {
      ++reached;
      reach = std::max(reach, sm.reach_cpu_s);
    } else {
      reach = kInf;
    }
    reached_quarter += sm.reach_cpu_s <= 0.25 * separate_cpu ? 1 : 0;
    reached_half += sm.reach_cpu_s <= 0.5 * separate_cpu ? 1 : 0;
    reached_1x += sm.reach_cpu_s <= separate_cpu ? 1 : 0;
    const double fractions[3] = {0.25, 0.5, 1.0};
    for (int k = 0; k < 3; ++k) {
      c_reached[k] += sm.reach_configs <= fractions[k] * separate_configs ? 1 : 0;
    }
    q.push_back(sm.risk_at_quarter / separate[m].risk);
    cq.push_back(sm.risk_at_quarter_configs / separate[m].risk);
  }
  std::sort(q.begin(), q.end());
  std::sort(cq.begin(), cq.end());
  state.counters["separate_cpu_s"] = separate_cpu;
  state.counters["shared_cpu_s"] = cpu_used;
  state.counters["shared_configs"] = configs_used;
  state.counters["reach_cpu_s"] = reach;
  state.counters["reach_ratio"] = reach / separate_cpu;
  state.counters["reached"] = reached;
  state.counters["q_median"] = q[q.size() / 2];
  state.counters["q_max"] = q.back();
  state.counters["reached_quarter"] = reached_quarter;
  state.counters["reached_half"] = reached_half;
  state.counters["reached_1x"] = reached_1x;
  state.counters["separate_configs"] = separate_configs;
  state.counters["c_reached_quarter"] = c_reached[0];
  state.counters["c_reached_half"] = c_reached[1];
  state.counters["c_reached_1x"] = c_reached[2];
  state.counters["cq_median"] = cq[cq.size() / 2];
  state.counters["cq_max"] = cq.back();
}
BENCHMARK(BM_SharedTree)->Unit(benchmark::kSecond)->Iterations(1);

void PrintTable() {
  const std::vector<Separate>& separate = SeparateResults();
  const std::vector<SharedMission>& shared = SharedResults();
  if (separate.empty() || shared.size() != separate.size()) return;
  const Fleet& fleet = TheFleet();
  std::printf("\ndepot (%.0f, %.0f); shared tree: %lld iterations, %lld nodes at its last report\n",
              fleet.depot.x, fleet.depot.y, static_cast<long long>(shared_iterations),
              static_cast<long long>(shared_tree_size));
  std::printf("%3s %14s %12s %8s %11s %11s %10s %11s\n", "#", "start", "separate", "cpu_s",
              "iterations", "@quarter", "reach_s", "final");
  for (size_t m = 0; m < separate.size(); ++m) {
    std::printf("%3zu (%5.0f,%5.0f) %12.4e %8.3f %11lld %11.4f %10.3f %11.4f\n", m,
                fleet.starts[m].x, fleet.starts[m].y, separate[m].risk, separate[m].cpu_s,
                static_cast<long long>(separate[m].iterations),
                shared[m].risk_at_quarter / separate[m].risk, shared[m].reach_cpu_s,
                shared[m].final_risk / separate[m].risk);
  }
  std::printf(
      "(@quarter and final: the shared tree's risk / the separate plan's; reach_s: CPU s\n"
      " of the shared tree when the mission first reached its separate plan's risk)\n");
}

}  // namespace
}  // namespace riskplan

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  absl::ParseCommandLine(argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  riskplan::PrintTable();
  benchmark::Shutdown();
  return 0;
}
