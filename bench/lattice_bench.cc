// riskplan-bench-lattice: how close RISK_RRT_STAR comes to the best route
// (issue 37). Per scenario it computes
// - the lower bound of core/planners/lower_bound.h (no route can beat it);
// - the state lattice's optimum (core/planners/state_lattice.h) at each
//   resolution of --lattices, its route re-evaluated with EvaluateTrajectory;
// - RISK_RRT_STAR without and with the cost-to-go guide (`guide` = 1), each
//   seed run once, its risk read off the improvements at every checkpoint of
//   --budgets in CPU seconds of the planning thread (the machine may be
//   loaded: CPU time is the work done; each run gets a wall-time budget of
//   --wall_factor x the last checkpoint);
// and prints medians and quartiles, the reference (the least risk any of them
// found) and every figure relative to it.
//
// Risks (lattice edges, guide field, planner runs) by accel's exact kernel, as
// riskplan-server computes them: the same risks bit for bit as the core's.
//
//   riskplan-bench-lattice [--scenarios=west-east,...] [--seeds=10]
//       [--budgets=0.1,0.3,1,3] [--lattices=400:8,200:16] [--bound_block_m=100]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/strings/str_split.h"
#include "accel/kernel_evaluator.h"
#include "bench/planner_runs.h"
#include "cmdline/help.h"
#include "core/flight/trajectory.h"
#include "core/flight/trajectory_piece.h"
#include "core/planners/cost_to_go_field.h"
#include "core/planners/lower_bound.h"
#include "core/planners/planner.h"
#include "core/planners/state_lattice.h"

ABSL_FLAG(std::string, scenarios,
          "west-east,south-north,sw-ne,nw-se,wsw-ene,5km-a,5km-b,suburb-w,short-u-turn,edge-2,"
          "readme",
          "comma-separated scenario names of bench/scenarios.h; 'readme' is the README's plan "
          "(1200,1500 to 6800,6500)");
ABSL_FLAG(int, seeds, 10, "seeds per scenario and planner");
ABSL_FLAG(std::string, budgets, "0.1,0.3,1,3", "checkpoints, CPU seconds of the planning thread");
ABSL_FLAG(double, wall_factor, 5.0, "wall-time budget of a run: this x the last checkpoint");
ABSL_FLAG(std::string, lattices, "400:8,250:16",
          "lattice resolutions spacing_m:headings[:levels], comma-separated; levels are offsets "
          "above the safe altitude in m, '/'-separated (default 3/25; empty: no lattice)");
ABSL_FLAG(double, bound_block_m, 50.0, "block of the lower bound, m");
ABSL_FLAG(std::string, modes, "unguided,guided",
          "RISK_RRT_STAR variants to run: unguided (guide = 0), guided (guide = 1), informed "
          "(guide = 1 and guide_informed = 1.25 unless --params sets it)");
ABSL_FLAG(std::string, params, "", "extra RISK_RRT_STAR parameters for every variant");

namespace riskplan {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
using bench::Median;
using bench::ThreadCpuSeconds;

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const double at = q * (v.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(at));
  const size_t hi = std::min(v.size() - 1, lo + 1);
  if (!std::isfinite(v[lo]) || !std::isfinite(v[hi])) return v[hi];
  return v[lo] + (at - lo) * (v[hi] - v[lo]);
}

std::vector<double> ParseList(const std::string& text) {
  std::vector<double> out;
  for (absl::string_view s : absl::StrSplit(text, ',', absl::SkipEmpty())) {
    out.push_back(std::stod(std::string(s)));
  }
  return out;
}

double Evaluate(const RiskModel& model, const std::vector<Pose>& w, bool* admissible) {
  std::vector<TrajectoryPiece> pieces;
  const ModelParams& mp = model.params();
  for (size_t k = 0; k + 1 < w.size(); ++k) {
    pieces.push_back(
        TrajectoryPiece::Manoeuvre(w[k], w[k + 1], mp.GroundTurnRadius(), mp.GroundClimbAngle()));
  }
  auto e = EvaluateTrajectory(model, pieces);
  *admissible = e.ok() && e->admissible;
  return e.ok() ? e->risk : kInf;
}

int Main() {
  auto runs = bench::LoadDemoCityRuns("");
  if (!runs.ok()) {
    std::fprintf(stderr, "%s\n", std::string(runs.status().message()).c_str());
    return 1;
  }
  const std::shared_ptr<const RiskModel>& model = runs->model;
  std::vector<bench::Scenario> scenarios;
  for (absl::string_view name : absl::StrSplit(absl::GetFlag(FLAGS_scenarios), ',')) {
    if (name == "readme") {
      // The README's plan: riskplan plan --start=1200,1500,250,0.785 --goal=6800,6500,250,0.785
      Pose s{1200, 1500, 250, 0.785};
      Pose g{6800, 6500, 250, 0.785};
      if (model->CheckConfiguration(s) != ViolationKind::kNone ||
          model->CheckConfiguration(g) != ViolationKind::kNone) {
        std::fprintf(stderr, "readme: start or goal not admissible\n");
        return 1;
      }
      scenarios.push_back({"readme", s, g, true});
      continue;
    }
    bool found = false;
    for (const bench::Scenario& sc : runs->scenarios) {
      if (sc.name == name) {
        scenarios.push_back(sc);
        found = true;
      }
    }
    if (!found) {
      std::fprintf(stderr, "unknown scenario '%s'\n", std::string(name).c_str());
      return 1;
    }
  }
  const int seeds = absl::GetFlag(FLAGS_seeds);
  const std::vector<double> budgets = ParseList(absl::GetFlag(FLAGS_budgets));
  const double wall = absl::GetFlag(FLAGS_wall_factor) * budgets.back();
  std::vector<std::string> modes =
      absl::StrSplit(absl::GetFlag(FLAGS_modes), ',', absl::SkipEmpty());
  for (const std::string& mode : modes) {
    if (mode != "unguided" && mode != "guided" && mode != "informed") {
      std::fprintf(stderr, "--modes: unknown variant '%s' (unguided, guided, informed)\n",
                   mode.c_str());
      return 1;
    }
  }
  const std::map<std::string, double> extra =
      bench::ParsePlannerParams(absl::GetFlag(FLAGS_params));
  // The guide field's lattice, as the planner builds it from its parameters.
  const LatticeOptions field_options = bench::GuideFieldOptions(extra);

  // The lower bound, once for the model.
  double cpu = ThreadCpuSeconds();
  LowerBoundOptions lbo;
  lbo.block_m = absl::GetFlag(FLAGS_bound_block_m);
  auto bound = RiskLowerBound::Build(model, lbo);
  if (!bound.ok()) {
    std::fprintf(stderr, "%s\n", std::string(bound.status().message()).c_str());
    return 1;
  }
  std::printf("lower bound: blocks %d x %d of %.0f m, built in %.2f CPU s\n", (*bound)->blocks_x(),
              (*bound)->blocks_y(), lbo.block_m, ThreadCpuSeconds() - cpu);

  // The lattices, one per resolution, their edge memo shared by the scenarios.
  struct Lat {
    std::string name;
    std::unique_ptr<StateLattice> lattice;
  };
  std::vector<Lat> lattices;
  for (absl::string_view spec :
       absl::StrSplit(absl::GetFlag(FLAGS_lattices), ',', absl::SkipEmpty())) {
    std::vector<std::string> parts = absl::StrSplit(spec, ':');
    LatticeOptions lo;
    lo.spacing_m = std::stod(parts[0]);
    lo.headings = parts.size() > 1 ? std::stoi(parts[1]) : 8;
    if (parts.size() > 2) {
      lo.level_offsets_m.clear();
      for (absl::string_view level : absl::StrSplit(parts[2], '/')) {
        lo.level_offsets_m.push_back(std::stod(std::string(level)));
      }
    }
    auto lattice = StateLattice::Create(*model, lo);
    if (!lattice.ok()) {
      std::fprintf(stderr, "%s\n", std::string(lattice.status().message()).c_str());
      return 1;
    }
    std::printf("lattice %s: %lld valid states of %lld, %zu primitives per heading\n",
                std::string(spec).c_str(), static_cast<long long>((*lattice)->valid_states()),
                static_cast<long long>((*lattice)->state_count()),
                (*lattice)->primitives_per_heading());
    lattices.push_back({std::string(spec), std::move(*lattice)});
  }
  std::fflush(stdout);

  // Risks by accel's exact kernel, as riskplan-server computes them (the same
  // risks bit for bit as DirectRiskEvaluator's, in less time).
  accel::KernelRiskEvaluator evaluator;
  for (const bench::Scenario& sc : scenarios) {
    std::printf("\n== %s\n", sc.name);
    const double lb = (*bound)->Query(sc.start, sc.goal);
    double reference = kInf;
    std::string reference_from;
    std::vector<std::pair<std::string, double>> lattice_risks;
    for (Lat& l : lattices) {
      LatticeSearchStats st;
      cpu = ThreadCpuSeconds();
      auto route = l.lattice->Solve(sc.start, sc.goal, &evaluator, {}, &st);
      const double used = ThreadCpuSeconds() - cpu;
      if (!route.ok()) {
        std::fprintf(stderr, "%s\n", std::string(route.status().message()).c_str());
        return 1;
      }
      if (!route->has_value()) {
        std::printf("lattice %-8s no route (%.1f CPU s)\n", l.name.c_str(), used);
        continue;
      }
      bool admissible = false;
      const double eval = Evaluate(*model, (*route)->waypoints, &admissible);
      std::printf(
          "lattice %-8s risk %.6e  EvaluateTrajectory %.6e (%s, %s)  %zu waypoints  %.1f CPU s  "
          "%lld states settled  %lld edges  %.1fM configurations\n",
          l.name.c_str(), (*route)->risk, eval, admissible ? "admissible" : "NOT ADMISSIBLE",
          eval == (*route)->risk ? "equal" : "DIFFERENT", (*route)->waypoints.size(), used,
          static_cast<long long>(st.states_settled), static_cast<long long>(st.edges_evaluated),
          st.configurations / 1e6);
      lattice_risks.push_back({l.name, eval});
      if (admissible && eval < reference) {
        reference = eval;
        reference_from = "lattice " + l.name;
      }
    }
    std::fflush(stdout);

    // The guide's field for this goal: built once, outside the runs' budgets.
    {
      cpu = ThreadCpuSeconds();
      auto field = GuideFieldCache::Default().Get(*model, sc.goal, field_options, &evaluator);
      if (!field.ok()) {
        std::fprintf(stderr, "%s\n", std::string(field.status().message()).c_str());
        return 1;
      }
      std::printf(
          "guide field (%.0f m, %d headings, %zu levels, %.0f m step): %.2f CPU s, %.2f MB, "
          "%.2fM configurations\n",
          field_options.spacing_m, field_options.headings, field_options.level_offsets_m.size(),
          field_options.risk_step_m, ThreadCpuSeconds() - cpu, (*field)->MemoryBytes() / 1e6,
          (*field)->build_stats().configurations / 1e6);
    }

    // risk_at[mode][budget] over seeds.
    std::map<std::string, std::vector<std::vector<double>>> at;
    std::map<std::string, std::vector<double>> cpu_used;
    for (int seed = 1; seed <= seeds; ++seed) {
      for (const std::string& mode : modes) {
        accel::KernelRiskEvaluator run_evaluator;  // one per run: it counts the run's
        auto planner = MakePlanner(PlannerAlgorithm::kRiskRrtStar, &run_evaluator);
        PlanOptions options;
        options.budget.max_time_s = wall;
        options.seed = seed;
        options.params = extra;
        options.params["guide"] = mode == "unguided" ? 0.0 : 1.0;
        if (mode == "informed") options.params.emplace("guide_informed", 1.25);
        CancellationToken cancel;
        std::vector<std::pair<double, double>> curve;  // CPU s, risk
        std::vector<Pose> best;
        const double cpu0 = ThreadCpuSeconds();
        auto result = (*planner)->Plan({model, sc.start, sc.goal}, options, cancel,
                                       [&](const PlanImprovement& i) {
                                         curve.push_back({ThreadCpuSeconds() - cpu0, i.risk});
                                       });
        const double used = ThreadCpuSeconds() - cpu0;
        if (!result.ok()) {
          std::fprintf(stderr, "%s\n", std::string(result.status().message()).c_str());
          return 1;
        }
        auto& row = at[mode];
        row.resize(budgets.size());
        for (size_t b = 0; b < budgets.size(); ++b) {
          double r = kInf;
          for (const auto& [t, risk] : curve) {
            if (t <= budgets[b]) r = risk;
          }
          row[b].push_back(r);
        }
        cpu_used[mode].push_back(used);
        if (result->best.has_value()) {
          bool admissible = false;
          const double eval = Evaluate(*model, result->best->waypoints, &admissible);
          if (eval != result->best->risk) {
            std::printf("run %s seed %d: reported %.17g, EvaluateTrajectory %.17g\n", mode.c_str(),
                        seed, result->best->risk, eval);
          }
          if (admissible && eval < reference) {
            reference = eval;
            reference_from = mode + " seed " + std::to_string(seed) + " (final)";
          }
          if (eval < lb) {
            std::printf("BOUND VIOLATED: %s seed %d risk %.9e < bound %.9e\n", mode.c_str(), seed,
                        eval, lb);
          }
        }
      }
    }
    std::printf("lower bound %.4e; reference %.4e (%s); reference / bound %.2f\n", lb, reference,
                reference_from.c_str(), reference / lb);
    for (const auto& [name, r] : lattice_risks) {
      std::printf("lattice %-8s / reference %.4f\n", name.c_str(), r / reference);
    }
    for (const std::string& mode : modes) {
      std::printf("%-9s CPU s per run (median) %.2f\n", mode.c_str(), Median(cpu_used[mode]));
      for (size_t b = 0; b < budgets.size(); ++b) {
        const std::vector<double>& v = at[mode][b];
        std::printf("%-9s @%4.1fs  median %.4e [%.4e, %.4e]  / reference %.4f [%.4f, %.4f]\n",
                    mode.c_str(), budgets[b], Median(v), Quantile(v, 0.25), Quantile(v, 0.75),
                    Median(v) / reference, Quantile(v, 0.25) / reference,
                    Quantile(v, 0.75) / reference);
      }
    }
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace
}  // namespace riskplan

int main(int argc, char** argv) {
  riskplan::cmdline::ParseCommandLine(
      argc, argv,
      {.program = "riskplan-bench-lattice",
       .usage = "reference optimum, lower bound and guided RISK_RRT_STAR (docs/benchmarks.md)."});
  return riskplan::Main();
}
