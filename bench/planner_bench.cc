// riskplan-bench-planner: anytime behaviour of a planner on the fixed
// demo-city scenario set (bench/scenarios.h).
//
// For every scenario and seed it runs the planner with a wall-time budget on
// one thread and records each improvement. It reports, per scenario and over
// all: tree nodes added per second, time to the first solution, and the best
// risk reached by 0.1, 0.3, 1 and 3 s (medians over seeds).
//
// The planner computes its risks as riskplan-server does: with accel's exact
// CPU kernel on the planning thread (--evaluator=kernel), or with the core's
// one-window loop (--evaluator=direct, the planner's own evaluator when it is
// given none). Both give the same risks bit for bit, so the same trees.
//
//   riskplan-bench-planner [--seeds=5] [--budget_s=3] [--scenarios=5km-a,west-east]
//                          [--evaluator=kernel|direct]
#include <algorithm>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "accel/kernel_evaluator.h"
#include "bench/planner_runs.h"
#include "cmdline/help.h"
#include "core/planners/planner.h"

ABSL_FLAG(int, seeds, 5, "seeds per scenario");
ABSL_FLAG(double, budget_s, 3.0, "wall-time budget per run, s");
ABSL_FLAG(std::string, scenarios, "", "comma-separated scenario names (empty: all)");
ABSL_FLAG(std::string, params, "", "planner parameters name=value,...");
ABSL_FLAG(int64_t, iterations, 0,
          "iteration budget per run instead of wall time (0: wall time); with --print_runs a "
          "reproducibility check");
ABSL_FLAG(std::string, evaluator, "kernel",
          "how the planner computes risks: kernel (accel's exact CPU kernel, as riskplan-server "
          "plans) or direct (the core's one-window loop); the same risks bit for bit");
ABSL_FLAG(bool, print_runs, false,
          "print every run: final risk (17 digits), tree size, configurations evaluated, CPU s");

namespace riskplan {
namespace {

using bench::Median;
using bench::ThreadCpuSeconds;

struct RunStats {
  double nodes_per_s = 0.0;
  double nodes_per_cpu_s = 0.0;  // per second of this thread's CPU time
  double configs_per_node = 0.0;
  double first_solution_s = std::nan("");  // NaN: none
  std::vector<double> risk_at;             // per checkpoint; +inf: none yet
};

constexpr double kCheckpoints[] = {0.1, 0.3, 1.0, 3.0};

int Main() {
  auto runs = bench::LoadDemoCityRuns(absl::GetFlag(FLAGS_scenarios));
  if (!runs.ok()) {
    std::fprintf(stderr, "%s\n", std::string(runs.status().message()).c_str());
    return 1;
  }
  const std::shared_ptr<const RiskModel>& model = runs->model;
  const std::vector<bench::Scenario>& scenarios = runs->scenarios;
  const std::map<std::string, double> params =
      bench::ParsePlannerParams(absl::GetFlag(FLAGS_params));
  const int seeds = absl::GetFlag(FLAGS_seeds);
  const double budget = absl::GetFlag(FLAGS_budget_s);
  const int64_t iterations = absl::GetFlag(FLAGS_iterations);
  const bool print_runs = absl::GetFlag(FLAGS_print_runs);
  const std::string evaluator_name = absl::GetFlag(FLAGS_evaluator);
  if (evaluator_name != "kernel" && evaluator_name != "direct") {
    std::fprintf(stderr, "--evaluator must be kernel or direct, not '%s'\n",
                 evaluator_name.c_str());
    return 1;
  }
  std::printf(
      "riskplan-bench-planner: RISK_RRT_STAR, %zu scenarios x %d seeds, %.1f s each, evaluator "
      "%s\n",
      scenarios.size(), seeds, budget, evaluator_name.c_str());
  std::printf("%-14s %8s %9s %10s %12s %12s %12s %12s %7s\n", "scenario", "nodes/s", "cfg/node",
              "first_ms", "risk@0.1s", "risk@0.3s", "risk@1s", "risk@3s", "solved");
  std::vector<double> all_nodes_per_s;
  std::vector<double> all_nodes_per_cpu_s;
  std::vector<double> all_first;
  for (const bench::Scenario& sc : scenarios) {
    std::vector<RunStats> runs;
    for (int seed = 1; seed <= seeds; ++seed) {
      // One evaluator per run: it counts the run's configurations.
      accel::KernelRiskEvaluator kernel;
      auto planner = MakePlanner(PlannerAlgorithm::kRiskRrtStar,
                                 evaluator_name == "kernel" ? &kernel : nullptr);
      PlanOptions options;
      options.budget.max_time_s = iterations > 0 ? 0.0 : budget;
      options.budget.max_iterations = iterations;
      options.seed = seed;
      options.params = params;
      CancellationToken cancel;
      std::vector<PlanImprovement> improvements;
      const double cpu_before = ThreadCpuSeconds();
      auto result = (*planner)->Plan({model, sc.start, sc.goal}, options, cancel,
                                     [&](const PlanImprovement& i) { improvements.push_back(i); });
      if (!result.ok()) {
        std::fprintf(stderr, "%s: %s\n", sc.name, std::string(result.status().message()).c_str());
        return 1;
      }
      RunStats stats;
      stats.nodes_per_s = result->tree_size / result->elapsed_s;
      const double cpu_s = ThreadCpuSeconds() - cpu_before;
      stats.nodes_per_cpu_s = result->tree_size / cpu_s;
      if (print_runs) {
        std::printf(
            "run %s seed %d: risk %.17g tree %lld iterations %lld configurations %llu cpu %.3f s\n",
            sc.name, seed, result->best.has_value() ? result->best->risk : -1.0,
            static_cast<long long>(result->tree_size), static_cast<long long>(result->iterations),
            static_cast<unsigned long long>(result->configurations_evaluated), cpu_s);
      }
      stats.configs_per_node =
          static_cast<double>(result->configurations_evaluated) / result->tree_size;
      if (!improvements.empty()) stats.first_solution_s = improvements.front().elapsed_s;
      for (double t : kCheckpoints) {
        double best = std::numeric_limits<double>::infinity();
        for (const PlanImprovement& i : improvements) {
          if (i.elapsed_s <= t) best = i.risk;
        }
        stats.risk_at.push_back(best);
      }
      runs.push_back(stats);
    }
    std::vector<double> nps, first, cpn;
    std::vector<std::vector<double>> at(std::size(kCheckpoints));
    int solved = 0;
    for (const RunStats& r : runs) {
      nps.push_back(r.nodes_per_s);
      cpn.push_back(r.configs_per_node);
      all_nodes_per_s.push_back(r.nodes_per_s);
      all_nodes_per_cpu_s.push_back(r.nodes_per_cpu_s);
      if (!std::isnan(r.first_solution_s)) {
        ++solved;
        first.push_back(r.first_solution_s * 1000.0);
        all_first.push_back(r.first_solution_s * 1000.0);
      }
      for (size_t c = 0; c < at.size(); ++c) at[c].push_back(r.risk_at[c]);
    }
    std::printf("%-14s %8.0f %9.0f %10.1f %12.4e %12.4e %12.4e %12.4e %4d/%d\n", sc.name,
                Median(nps), Median(cpn), Median(first), Median(at[0]), Median(at[1]),
                Median(at[2]), Median(at[3]), solved, seeds);
  }
  std::printf(
      "all scenarios: median nodes/s %.0f (per CPU second of the planner's thread: %.0f), median "
      "time to first solution %.1f ms\n",
      Median(all_nodes_per_s), Median(all_nodes_per_cpu_s), Median(all_first));
  return 0;
}

}  // namespace
}  // namespace riskplan

int main(int argc, char** argv) {
  riskplan::cmdline::ParseCommandLine(
      argc, argv,
      {.program = "riskplan-bench-planner",
       .usage = "anytime planner benchmark on the demo-city scenarios (docs/benchmarks.md)."});
  return riskplan::Main();
}
