// riskplan-bench-ompl: RISK_RRT_STAR side by side with OMPL 1.5's RRT*,
// Informed RRT*, BIT* and ABIT* on the same demo-city problems (issue 7, part 1).
//
// Every (planner, scenario, seed) runs in its own child process, one at a
// time: OMPL's RNG takes its seed once per process, and a fresh process gives
// every planner the same start (the parent builds the map and model once; the
// children inherit them). Each run has the full wall-time budget and records
// its anytime curve (every improvement with its time and iteration count), so
// the risk reached by each smaller budget is read off the same run; the
// iteration counts at the smaller budgets come from OMPL's termination
// condition for OMPL, and from extra runs with those budgets for
// RISK_RRT_STAR. The report is CSV on stdout (bench/ompl/run_record.h);
// bench/ompl/plot_ompl_bench.py turns it into the table and the plot.
//
//   riskplan-bench-ompl [--planners=...] [--scenarios=...] [--seeds=10]
//                       [--budget_s=3] [--self_check]
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "bench/ompl/ompl_runs.h"
#include "bench/ompl/run_record.h"
#include "bench/ompl/self_check.h"
#include "bench/scenarios.h"
#include "cmdline/help.h"
#include "core/flight/trajectory.h"
#include "core/map/demo_city.h"
#include "core/planners/planner.h"
#include "ompl/util/Console.h"

// Ten of the 24 scenarios: seven across the dense centre (both 5 km ones
// among them) and three others (a suburb leg, a short U-turn, the centre's
// edge).
constexpr char kDefaultScenarios[] =
    "west-east,south-north,sw-ne,nw-se,wsw-ene,5km-a,5km-b,suburb-w,short-u-turn,edge-2";

ABSL_FLAG(std::string, planners, "RISK_RRT_STAR,RRTstar,InformedRRTstar,BITstar,ABITstar",
          "comma-separated planners: RISK_RRT_STAR and OMPL's RRTstar, InformedRRTstar, BITstar, "
          "ABITstar");
ABSL_FLAG(std::string, scenarios, kDefaultScenarios, "comma-separated scenario names");
ABSL_FLAG(int, seeds, 10, "seeds per scenario");
ABSL_FLAG(int, first_seed, 1, "first seed (seeds first_seed, first_seed + 1, ...)");
ABSL_FLAG(double, budget_s, 3.0, "wall-time budget of every run, s");
ABSL_FLAG(std::string, checkpoints, "0.1,0.3,1,3", "budgets reported, s (ascending, <= budget_s)");
ABSL_FLAG(bool, ours_budget_runs, true,
          "also run RISK_RRT_STAR once per checkpoint below budget_s with that budget, for its "
          "iteration counts");
ABSL_FLAG(std::string, params, "", "RISK_RRT_STAR parameters name=value,...");
ABSL_FLAG(std::string, ours_clock, "wall",
          "RISK_RRT_STAR's improvement times: wall (elapsed, as every planner's) or cpu (CPU time "
          "of its thread: for quick comparisons on a loaded machine, never mixed with wall times "
          "in one report)");
ABSL_FLAG(std::string, label, "", "suffix appended to OMPL planner names (tuning runs)");
ABSL_FLAG(double, rrt_range_m, 400.0, "RRT*/Informed RRT*: range (longest extension), m");
ABSL_FLAG(double, rrt_rewire_factor, 1.1, "RRT*/Informed RRT*: rewire factor");
ABSL_FLAG(bool, rrt_k_nearest, true, "RRT*/Informed RRT*: k-nearest (else radius) rule");
ABSL_FLAG(std::string, rrt_nn, "grid", "RRT*/Informed RRT*: grid, sqrtapprox or linear");
ABSL_FLAG(double, grid_cell_m, 200.0, "cell of the grid nearest-neighbour structure, m");
ABSL_FLAG(bool, irrt_admissible_cost_to_come, false,
          "Informed RRT*: prune with motionCost(start, x) as cost-to-come (OMPL's default)");
ABSL_FLAG(int, bit_samples, 100, "BIT* and ABIT*: samples per batch");
ABSL_FLAG(double, bit_rewire_factor, 1.1, "BIT* and ABIT*: rewire factor");
ABSL_FLAG(bool, bit_k_nearest, true, "BIT* and ABIT*: k-nearest (else r-disc) rule");
ABSL_FLAG(double, abit_initial_inflation, 1e6, "ABIT*: initial inflation factor");
ABSL_FLAG(double, abit_inflation_scaling, 10, "ABIT*: inflation scaling parameter");
ABSL_FLAG(double, abit_truncation_scaling, 5, "ABIT*: truncation scaling parameter");
ABSL_FLAG(bool, self_check, false, "check the OMPL adapter against EvaluateTrajectory and exit");
ABSL_FLAG(int, self_check_edges, 300, "random edges of the self-check");

namespace riskplan::bench {
namespace {

constexpr char kOurs[] = "RISK_RRT_STAR";

// Runs `body` in a child process and waits for it. Returns its exit status
// (128 + signal when it died of one).
int RunInChild(const std::function<int()>& body) {
  std::fflush(stdout);
  std::fflush(stderr);
  const pid_t pid = fork();
  if (pid < 0) {
    std::perror("fork");
    return 127;
  }
  if (pid == 0) {
    const int rc = body();
    std::fflush(stdout);
    std::fflush(stderr);
    _exit(rc);
  }
  int status = 0;
  if (waitpid(pid, &status, 0) < 0) return 127;
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  return 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
}

// The first three fields of /proc/loadavg ("?" when unreadable).
std::string LoadAverage() {
  std::FILE* f = std::fopen("/proc/loadavg", "r");
  if (f == nullptr) return "?";
  double one = 0.0;
  double five = 0.0;
  double fifteen = 0.0;
  const int n = std::fscanf(f, "%lf %lf %lf", &one, &five, &fifteen);
  std::fclose(f);
  if (n != 3) return "?";
  char text[64];
  std::snprintf(text, sizeof(text), "%.2f %.2f %.2f", one, five, fifteen);
  return text;
}

double ThreadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

absl::StatusOr<RunRecord> RunOurs(std::shared_ptr<const RiskModel> model, const Scenario& scenario,
                                  uint64_t seed, double budget_s,
                                  const std::map<std::string, double>& params, bool cpu_clock) {
  auto planner = MakePlanner(PlannerAlgorithm::kRiskRrtStar);
  if (!planner.ok()) return planner.status();
  PlanOptions options;
  options.budget.max_time_s = budget_s;
  options.seed = seed;
  options.params = params;
  CancellationToken cancel;
  RunRecord record;
  record.planner = kOurs;
  record.scenario = scenario.name;
  record.seed = seed;
  record.budget_s = budget_s;
  const double cpu_start = ThreadCpuSeconds();
  auto result = (*planner)->Plan(
      {model, scenario.start, scenario.goal}, options, cancel, [&](const PlanImprovement& i) {
        const double t = cpu_clock ? ThreadCpuSeconds() - cpu_start : i.elapsed_s;
        record.improvements.push_back({t, i.risk, i.iterations});
      });
  if (!result.ok()) return result.status();
  record.elapsed_s = result->elapsed_s;
  record.iterations = result->iterations;
  record.vertices = result->tree_size;
  record.configurations = result->configurations_evaluated;
  record.checkpoint_iterations.push_back({budget_s, result->iterations});
  record.solved = result->best.has_value();
  if (record.solved) {
    record.best_risk = result->best->risk;
    auto pieces = PiecesFromWaypoints(result->best->waypoints, model->params());
    if (!pieces.ok()) return pieces.status();
    auto evaluation = EvaluateTrajectory(*model, *pieces);
    if (!evaluation.ok()) return evaluation.status();
    record.reevaluated_risk = evaluation->risk;
    record.reevaluated_admissible = evaluation->admissible;
  }
  return record;
}

int Main() {
  ompl::msg::setLogLevel(std::getenv("RISKPLAN_OMPL_DEBUG") != nullptr ? ompl::msg::LOG_DEBUG
                                                                       : ompl::msg::LOG_WARN);
  auto map = MakeDemoCity();
  if (!map.ok()) {
    std::fprintf(stderr, "%s\n", std::string(map.status().message()).c_str());
    return 1;
  }
  auto model_or = RiskModel::Create(*map, ModelParams{});
  if (!model_or.ok()) {
    std::fprintf(stderr, "%s\n", std::string(model_or.status().message()).c_str());
    return 1;
  }
  std::shared_ptr<const RiskModel> model = *model_or;
  if (absl::GetFlag(FLAGS_self_check)) {
    // In a child too: the check must not seed OMPL's generators here.
    return RunInChild(
        [&] { return RunSelfCheck(model, absl::GetFlag(FLAGS_self_check_edges)) ? 0 : 1; });
  }

  std::vector<Scenario> all = DemoCityScenarios(*model);
  std::vector<Scenario> scenarios;
  for (absl::string_view name : absl::StrSplit(absl::GetFlag(FLAGS_scenarios), ',')) {
    auto it =
        std::find_if(all.begin(), all.end(), [&](const Scenario& s) { return name == s.name; });
    if (it == all.end()) {
      std::fprintf(stderr, "unknown scenario '%s'\n", std::string(name).c_str());
      return 1;
    }
    scenarios.push_back(*it);
  }
  std::vector<std::string> planners = absl::StrSplit(absl::GetFlag(FLAGS_planners), ',');
  for (const std::string& p : planners) {
    if (p != kOurs && !IsOmplPlanner(p)) {
      std::fprintf(stderr, "unknown planner '%s'\n", p.c_str());
      return 1;
    }
  }
  const double budget = absl::GetFlag(FLAGS_budget_s);
  std::vector<double> checkpoints;
  for (absl::string_view c : absl::StrSplit(absl::GetFlag(FLAGS_checkpoints), ',')) {
    checkpoints.push_back(std::stod(std::string(c)));
  }
  std::map<std::string, double> params;
  for (absl::string_view kv : absl::StrSplit(absl::GetFlag(FLAGS_params), ',', absl::SkipEmpty())) {
    std::vector<std::string> parts = absl::StrSplit(kv, '=');
    if (parts.size() == 2) params[parts[0]] = std::stod(parts[1]);
  }
  OmplSettings settings;
  settings.rrt_range_m = absl::GetFlag(FLAGS_rrt_range_m);
  settings.rrt_rewire_factor = absl::GetFlag(FLAGS_rrt_rewire_factor);
  settings.rrt_k_nearest = absl::GetFlag(FLAGS_rrt_k_nearest);
  settings.rrt_nn = absl::GetFlag(FLAGS_rrt_nn);
  settings.grid_cell_m = absl::GetFlag(FLAGS_grid_cell_m);
  settings.irrt_admissible_cost_to_come = absl::GetFlag(FLAGS_irrt_admissible_cost_to_come);
  settings.bit_samples_per_batch = static_cast<unsigned>(absl::GetFlag(FLAGS_bit_samples));
  settings.bit_rewire_factor = absl::GetFlag(FLAGS_bit_rewire_factor);
  settings.bit_k_nearest = absl::GetFlag(FLAGS_bit_k_nearest);
  settings.abit_initial_inflation = absl::GetFlag(FLAGS_abit_initial_inflation);
  settings.abit_inflation_scaling = absl::GetFlag(FLAGS_abit_inflation_scaling);
  settings.abit_truncation_scaling = absl::GetFlag(FLAGS_abit_truncation_scaling);
  const std::string label = absl::GetFlag(FLAGS_label);
  const std::string clock = absl::GetFlag(FLAGS_ours_clock);
  if (clock != "wall" && clock != "cpu") {
    std::fprintf(stderr, "--ours_clock must be wall or cpu, not '%s'\n", clock.c_str());
    return 1;
  }
  const bool cpu_clock = clock == "cpu";
  const int seeds = absl::GetFlag(FLAGS_seeds);
  const int first_seed = absl::GetFlag(FLAGS_first_seed);

  std::vector<std::string> names;
  for (const Scenario& s : scenarios) names.push_back(s.name);
  std::printf(
      "# riskplan-bench-ompl: %zu scenarios (%s) x %d seeds (from %d) x %zu planners, %g s each\n",
      scenarios.size(), absl::StrJoin(names, " ").c_str(), seeds, first_seed, planners.size(),
      budget);
  std::printf(
      "# settings: rrt_range_m=%g rrt_rewire_factor=%g rrt_k_nearest=%d rrt_nn=%s "
      "grid_cell_m=%g irrt_admissible_cost_to_come=%d bit_samples=%u bit_rewire_factor=%g "
      "bit_k_nearest=%d abit_initial_inflation=%g abit_inflation_scaling=%g "
      "abit_truncation_scaling=%g label=%s params=%s ours_clock=%s\n",
      settings.rrt_range_m, settings.rrt_rewire_factor, settings.rrt_k_nearest ? 1 : 0,
      settings.rrt_nn.c_str(), settings.grid_cell_m, settings.irrt_admissible_cost_to_come ? 1 : 0,
      settings.bit_samples_per_batch, settings.bit_rewire_factor, settings.bit_k_nearest ? 1 : 0,
      settings.abit_initial_inflation, settings.abit_inflation_scaling,
      settings.abit_truncation_scaling, label.c_str(), absl::GetFlag(FLAGS_params).c_str(),
      clock.c_str());

  int failures = 0;
  for (const Scenario& scenario : scenarios) {
    for (int seed = first_seed; seed < first_seed + seeds; ++seed) {
      // The machine is shared: the load each group of runs saw goes into the report.
      std::printf("# load %s %d: %s\n", scenario.name, seed, LoadAverage().c_str());
      for (const std::string& planner : planners) {
        std::fprintf(stderr, "%s %s seed %d\n", planner.c_str(), scenario.name, seed);
        const int rc = RunInChild([&] {
          absl::StatusOr<RunRecord> record =
              planner == kOurs
                  ? RunOurs(model, scenario, seed, budget, params, cpu_clock)
                  : RunOmplPlanner(planner, model, scenario, seed, budget, checkpoints, settings);
          if (!record.ok()) {
            std::fprintf(stderr, "%s %s seed %d: %s\n", planner.c_str(), scenario.name, seed,
                         std::string(record.status().message()).c_str());
            return 1;
          }
          if (planner != kOurs) record->planner += label;
          PrintRecord(*record);
          return 0;
        });
        if (rc != 0) {
          ++failures;
          std::printf("err,%s%s,%s,%d,%d\n", planner.c_str(), planner == kOurs ? "" : label.c_str(),
                      scenario.name, seed, rc);
        }
        if (planner != kOurs || !absl::GetFlag(FLAGS_ours_budget_runs)) continue;
        // RISK_RRT_STAR's iterations within each smaller budget.
        for (double b : checkpoints) {
          if (b >= budget) continue;
          RunInChild([&] {
            auto record = RunOurs(model, scenario, seed, b, params, cpu_clock);
            if (!record.ok()) return 1;
            std::printf("chk,%s,%s,%d,%g,%lld\n", kOurs, scenario.name, seed, b,
                        static_cast<long long>(record->iterations));
            std::printf("bud,%s,%s,%d,%g,%d,%.17g\n", kOurs, scenario.name, seed, b,
                        record->solved ? 1 : 0, record->best_risk);
            return 0;
          });
        }
      }
    }
  }
  return failures == 0 ? 0 : 1;
}

}  // namespace
}  // namespace riskplan::bench

int main(int argc, char** argv) {
  riskplan::cmdline::ParseCommandLine(
      argc, argv,
      {.program = "riskplan-bench-ompl",
       .usage = "RISK_RRT_STAR against OMPL's RRT*, Informed RRT*, BIT* and ABIT* on demo-city "
                "(docs/benchmarks.md)."});
  return riskplan::bench::Main();
}
