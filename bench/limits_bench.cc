// riskplan-bench-limits: RISK_RRT_STAR under flight limits on the README's
// demo (demo-city, start 1200,1500,250,0.785, goal 6800,6500,250,0.785), in
// process through MakePlanner (so through the limit filter, as the server
// plans), one plan after the other (docs/benchmarks.md, "Limits on the demo"):
//
//  free       MIN_RISK without a limit (seed 1): the reference risk and time;
//  endurance  MIN_RISK with --endurance_s for each of --seeds: each plan's
//             flight time and risk, and each risk against the best of them;
//  infeasible MIN_RISK with --infeasible_s (no route fits): the note;
//  quickest   MIN_TIME with max_risk twice the free plan's risk (seed 1): its
//             flight time against the free plan's.
//
// Every returned trajectory is evaluated again with EvaluateTrajectory: its
// risk and flight time must equal the plan's bit for bit ("exact" in the
// output) and meet the limit. Wall-time budgets: the iteration counts, and so
// the numbers, vary with the machine's load.
//
//   riskplan-bench-limits [--parts=free,endurance,infeasible,quickest]
//                         [--budget_s=10] [--seeds=1,2,3,4,5]
//                         [--endurance_s=600] [--infeasible_s=200] [--params=]
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
#include "bench/planner_runs.h"
#include "cmdline/help.h"
#include "core/flight/trajectory.h"
#include "core/flight/trajectory_piece.h"
#include "core/planners/planner.h"

ABSL_FLAG(std::string, parts, "free,endurance,infeasible,quickest", "comma-separated parts");
ABSL_FLAG(double, budget_s, 10.0, "wall-time budget of each plan, s");
ABSL_FLAG(std::string, seeds, "1,2,3,4,5", "endurance: the seeds");
ABSL_FLAG(double, endurance_s, 600.0, "endurance: max_flight_time_s");
ABSL_FLAG(double, infeasible_s, 200.0, "infeasible: max_flight_time_s no route meets");
ABSL_FLAG(std::string, params, "", "RISK_RRT_STAR parameters, name=value,...");

namespace riskplan {
namespace {

bool Wanted(const std::string& parts, const char* part) {
  for (absl::string_view p : absl::StrSplit(parts, ',')) {
    if (p == part) return true;
  }
  return false;
}

struct Outcome {
  bool has = false;
  double risk = 0.0;
  double time_s = 0.0;
  double length_m = 0.0;
  bool exact = false;  // EvaluateTrajectory gives the same risk and time, bit for bit
  int64_t iterations = 0;
  std::string reason;
  std::string note;
};

Outcome PlanOnce(const std::shared_ptr<const RiskModel>& model, uint64_t seed,
                 const FlightLimits& limits) {
  Outcome out;
  auto planner = MakePlanner(PlannerAlgorithm::kRiskRrtStar);
  if (!planner.ok()) {
    std::fprintf(stderr, "%s\n", std::string(planner.status().message()).c_str());
    std::exit(1);
  }
  PlanningProblem problem{model, Pose{1200, 1500, 250, 0.785}, Pose{6800, 6500, 250, 0.785}};
  PlanOptions options;
  options.budget.max_time_s = absl::GetFlag(FLAGS_budget_s);
  options.seed = seed;
  options.limits = limits;
  options.params = bench::ParsePlannerParams(absl::GetFlag(FLAGS_params));
  CancellationToken cancel;
  auto result = (*planner)->Plan(problem, options, cancel, nullptr);
  if (!result.ok()) {
    std::fprintf(stderr, "%s\n", std::string(result.status().message()).c_str());
    std::exit(1);
  }
  out.iterations = result->iterations;
  out.reason = std::string(StopReasonName(result->reason));
  out.note = result->limits.note;
  if (!result->best.has_value()) return out;
  out.has = true;
  const PlanImprovement& best = *result->best;
  out.risk = best.risk;
  out.length_m = best.length_m;
  std::vector<TrajectoryPiece> pieces;
  const ModelParams& mp = model->params();
  for (size_t k = 0; k + 1 < best.waypoints.size(); ++k) {
    pieces.push_back(TrajectoryPiece::Manoeuvre(best.waypoints[k], best.waypoints[k + 1],
                                                mp.GroundTurnRadius(), mp.GroundClimbAngle()));
  }
  auto e = EvaluateTrajectory(*model, pieces);
  out.time_s = e.ok() ? e->flight_time_s : std::nan("");
  // Without limits the filter is not run and the plan reports no flight time.
  out.exact = e.ok() && e->admissible && e->risk == best.risk &&
              (!limits.Active() || e->flight_time_s == best.flight_time_s);
  return out;
}

void Print(const char* label, const Outcome& o) {
  if (!o.has) {
    std::printf("%-34s %-16s iters %7lld  note: %s\n", label, o.reason.c_str(),
                static_cast<long long>(o.iterations), o.note.c_str());
  } else {
    std::printf("%-34s %-16s iters %7lld  time %7.1f s  risk %.4e  length %8.1f m  exact %d\n",
                label, o.reason.c_str(), static_cast<long long>(o.iterations), o.time_s, o.risk,
                o.length_m, o.exact ? 1 : 0);
  }
  std::fflush(stdout);
}

int Main() {
  auto runs = bench::LoadDemoCityRuns("none");
  if (!runs.ok()) {
    std::fprintf(stderr, "%s\n", std::string(runs.status().message()).c_str());
    return 1;
  }
  const std::shared_ptr<const RiskModel>& model = runs->model;
  const std::string parts = absl::GetFlag(FLAGS_parts);
  std::printf("RISK_RRT_STAR on the README's demo, %.1f s wall-time budgets, params '%s'\n",
              absl::GetFlag(FLAGS_budget_s), absl::GetFlag(FLAGS_params).c_str());
  std::optional<Outcome> free;
  if (Wanted(parts, "free") || Wanted(parts, "quickest")) {
    free = PlanOnce(model, 1, FlightLimits{});
    // Without limits the plan reports no flight time: EvaluateTrajectory's.
    Print("MIN_RISK, no limit, seed 1", *free);
  }
  if (Wanted(parts, "endurance")) {
    FlightLimits limits;
    limits.max_flight_time_s = absl::GetFlag(FLAGS_endurance_s);
    std::vector<std::pair<int, Outcome>> all;
    for (absl::string_view s : absl::StrSplit(absl::GetFlag(FLAGS_seeds), ',', absl::SkipEmpty())) {
      const int seed = std::stoi(std::string(s));
      Outcome o = PlanOnce(model, seed, limits);
      char label[64];
      std::snprintf(label, sizeof(label), "MIN_RISK, endurance %g s, seed %d",
                    limits.max_flight_time_s, seed);
      Print(label, o);
      all.push_back({seed, o});
    }
    double best = std::numeric_limits<double>::infinity();
    int best_seed = 0;
    for (const auto& [seed, o] : all) {
      if (o.has && o.risk < best) {
        best = o.risk;
        best_seed = seed;
      }
    }
    for (const auto& [seed, o] : all) {
      if (!o.has) continue;
      std::printf("  seed %d: %+.1f %% against the best of the seeds (seed %d, %.4e)%s\n", seed,
                  100.0 * (o.risk / best - 1.0), best_seed, best,
                  o.time_s <= limits.max_flight_time_s ? "" : "  BREAKS THE LIMIT");
    }
  }
  if (Wanted(parts, "infeasible")) {
    FlightLimits limits;
    limits.max_flight_time_s = absl::GetFlag(FLAGS_infeasible_s);
    char label[64];
    std::snprintf(label, sizeof(label), "MIN_RISK, endurance %g s", limits.max_flight_time_s);
    Print(label, PlanOnce(model, 1, limits));
  }
  if (Wanted(parts, "quickest") && free->has) {
    FlightLimits limits;
    limits.objective = PlanObjective::kMinTime;
    limits.max_risk = 2.0 * free->risk;
    char label[64];
    std::snprintf(label, sizeof(label), "MIN_TIME, max_risk %.3e", limits.max_risk);
    const Outcome o = PlanOnce(model, 1, limits);
    Print(label, o);
    if (o.has) {
      std::printf("  %.1f s (%.1f %%) quicker than MIN_RISK; risk %.1f %% of the limit\n",
                  free->time_s - o.time_s, 100.0 * (1.0 - o.time_s / free->time_s),
                  100.0 * o.risk / limits.max_risk);
    }
  }
  return 0;
}

}  // namespace
}  // namespace riskplan

int main(int argc, char** argv) {
  riskplan::cmdline::ParseCommandLine(
      argc, argv,
      {.program = "riskplan-bench-limits",
       .usage = "RISK_RRT_STAR under flight limits on the README's demo (docs/benchmarks.md)."});
  return riskplan::Main();
}
