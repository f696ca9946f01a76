// riskplan-bench-compare: every planner on the same demo-city scenarios
// (bench/scenarios.h), one thread, the same budget: success rate, risk,
// length and time, for the table of docs/planners.md.
//
// For each planner, scenario and seed it runs one plan and records the final
// trajectory (risk, length), the time of the first and of the last
// improvement, and whether the result passes an independent
// EvaluateTrajectory (admissible, same risk). Medians are over the solved
// runs.
//
//   riskplan-bench-compare [--seeds=3] [--budget_s=2] [--planners=RRT,GENETIC]
//                          [--scenarios=5km-a,west-east] [--per_scenario]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/strings/str_split.h"
#include "bench/planner_runs.h"
#include "cmdline/help.h"
#include "core/flight/trajectory.h"
#include "core/planners/planner.h"

ABSL_FLAG(int, seeds, 3, "seeds per scenario");
ABSL_FLAG(double, budget_s, 2.0, "wall-time budget per run, s");
ABSL_FLAG(std::string, planners, "RISK_RRT_STAR,RRT,GENETIC,HARMONIC",
          "comma-separated planner names");
ABSL_FLAG(std::string, scenarios, "", "comma-separated scenario names (empty: all)");
ABSL_FLAG(std::string, params, "", "planner parameters name=value,... (every planner)");
ABSL_FLAG(bool, per_scenario, false, "print one line per planner and scenario");

namespace riskplan {
namespace {

using bench::Median;

struct Totals {
  int runs = 0;
  int solved = 0;
  int verified = 0;
  std::vector<double> risk;
  std::vector<double> length_km;
  std::vector<double> first_s;
  std::vector<double> last_s;
  std::vector<double> risk_ratio;  // risk / RISK_RRT_STAR's median risk on the scenario
};

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
  const std::map<std::string, PlannerAlgorithm> by_name = {
      {"RISK_RRT_STAR", PlannerAlgorithm::kRiskRrtStar},
      {"RRT", PlannerAlgorithm::kRrt},
      {"GENETIC", PlannerAlgorithm::kGenetic},
      {"HARMONIC", PlannerAlgorithm::kHarmonic}};
  std::vector<std::string> planners = absl::StrSplit(absl::GetFlag(FLAGS_planners), ',');
  const int seeds = absl::GetFlag(FLAGS_seeds);
  const double budget = absl::GetFlag(FLAGS_budget_s);
  std::printf("riskplan-bench-compare: %zu scenarios x %d seeds, %.1f s budget each\n",
              scenarios.size(), seeds, budget);
  // Median risk per scenario of the first planner, the reference of risk_ratio.
  std::map<std::string, double> reference;
  std::vector<std::pair<std::string, Totals>> table;
  for (const std::string& name : planners) {
    auto it = by_name.find(name);
    if (it == by_name.end()) {
      std::fprintf(stderr, "unknown planner %s\n", name.c_str());
      return 1;
    }
    Totals totals;
    for (const bench::Scenario& sc : scenarios) {
      std::vector<double> risks;
      std::vector<double> times;
      int solved = 0;
      for (int seed = 1; seed <= seeds; ++seed) {
        auto planner = MakePlanner(it->second);
        PlanOptions options;
        options.budget.max_time_s = budget;
        options.seed = seed;
        for (const auto& [k, v] : params) {
          for (const PlannerParamInfo& info : PlannerParams(it->second)) {
            if (info.name == k) options.params[k] = v;
          }
        }
        CancellationToken cancel;
        std::vector<PlanImprovement> improvements;
        auto result =
            (*planner)->Plan({model, sc.start, sc.goal}, options, cancel,
                             [&](const PlanImprovement& i) { improvements.push_back(i); });
        if (!result.ok()) {
          std::fprintf(stderr, "%s %s: %s\n", name.c_str(), sc.name,
                       std::string(result.status().message()).c_str());
          return 1;
        }
        ++totals.runs;
        if (!result->best.has_value()) continue;
        ++totals.solved;
        ++solved;
        const PlanImprovement& best = *result->best;
        auto pieces = PiecesFromWaypoints(best.waypoints, model->params());
        auto eval = EvaluateTrajectory(*model, *pieces);
        if (eval.ok() && eval->admissible && eval->risk == best.risk) ++totals.verified;
        totals.risk.push_back(best.risk);
        risks.push_back(best.risk);
        totals.length_km.push_back(best.length_m / 1000.0);
        totals.first_s.push_back(improvements.front().elapsed_s);
        totals.last_s.push_back(improvements.back().elapsed_s);
        times.push_back(improvements.back().elapsed_s);
      }
      if (!risks.empty()) {
        const double median = Median(risks);
        if (!reference.contains(sc.name)) reference[sc.name] = median;
        totals.risk_ratio.push_back(median / reference[sc.name]);
      }
      if (absl::GetFlag(FLAGS_per_scenario)) {
        std::printf("  %-14s %-14s solved %d/%d  risk %.3e  last improvement %.3f s\n",
                    name.c_str(), sc.name, solved, seeds, Median(risks), Median(times));
      }
    }
    table.push_back({name, totals});
  }
  std::printf("%-14s %9s %9s %12s %10s %10s %10s %10s\n", "planner", "solved", "verified", "risk",
              "risk/ref", "length_km", "first_s", "last_s");
  for (const auto& [name, t] : table) {
    std::printf("%-14s %4d/%-4d %4d/%-4d %12.3e %10.2f %10.2f %10.3f %10.3f\n", name.c_str(),
                t.solved, t.runs, t.verified, t.solved, Median(t.risk), Median(t.risk_ratio),
                Median(t.length_km), Median(t.first_s), Median(t.last_s));
  }
  std::printf(
      "risk, length, first_s (first improvement) and last_s (last improvement): medians "
      "over solved runs; risk/ref: median over scenarios of the planner's median risk "
      "divided by the first planner's\n");
  return 0;
}

}  // namespace
}  // namespace riskplan

int main(int argc, char** argv) {
  riskplan::cmdline::ParseCommandLine(
      argc, argv,
      {.program = "riskplan-bench-compare",
       .usage = "every planner on the demo-city scenarios, same budget (docs/benchmarks.md)."});
  return riskplan::Main();
}
