// riskplan-bench-fingerprint: a bit-exact fingerprint of every planner's final
// trajectory on every demo-city scenario (bench/scenarios.h) and of
// EvaluateTrajectory on each scenario's straight line and Dubins join, for a
// change that must not change any result (a refactor): run it before and
// after and diff the outputs.
//
// Budgets are iterations, not time, so every run is reproducible bit for bit
// (RISK_RRT_STAR 1,500 iterations, RRT 3,000, GENETIC 30 generations,
// HARMONIC 400 sweeps; seed 7). Each line gives the stop reason, the risk
// and length as hexadecimal floats, the counts, and an FNV-1a hash of the
// waypoints' (x, y, z, theta) bits (of the samples' risks and arc lengths for
// evaluations). About 20 s on one core.
//
//   riskplan-bench-fingerprint [--eval_only] > fingerprint.txt
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "bench/scenarios.h"
#include "cmdline/help.h"
#include "core/flight/trajectory.h"
#include "core/map/demo_city.h"
#include "core/planners/planner.h"

ABSL_FLAG(bool, eval_only, false, "only the evaluations, no planner runs");

namespace riskplan {
namespace {
uint64_t Fnv(uint64_t h, double v) {
  uint64_t bits;
  std::memcpy(&bits, &v, 8);
  for (int i = 0; i < 8; ++i) {
    h ^= (bits >> (8 * i)) & 0xff;
    h *= 1099511628211ull;
  }
  return h;
}
int Main() {
  auto map = MakeDemoCity();
  if (!map.ok()) return 1;
  auto model = RiskModel::Create(*map, ModelParams{});
  if (!model.ok()) return 1;
  const auto scenarios = bench::DemoCityScenarios(**model);
  struct Algo {
    const char* name;
    PlannerAlgorithm a;
    int64_t iters;
  };
  const Algo algos[] = {{"RISK_RRT_STAR", PlannerAlgorithm::kRiskRrtStar, 1500},
                        {"RRT", PlannerAlgorithm::kRrt, 3000},
                        {"GENETIC", PlannerAlgorithm::kGenetic, 30},
                        {"HARMONIC", PlannerAlgorithm::kHarmonic, 400}};
  const bool only_eval = absl::GetFlag(FLAGS_eval_only);
  for (const auto& sc : scenarios) {
    // EvaluateTrajectory on the straight line and on the Dubins join.
    std::vector<Point3> line = {{sc.start.x, sc.start.y, sc.start.z},
                                {sc.goal.x, sc.goal.y, sc.goal.z}};
    auto lp = PiecesFromPolyline(line);
    std::vector<Pose> wp = {sc.start, sc.goal};
    auto dp = PiecesFromWaypoints(wp, (*model)->params());
    for (auto* pieces : {&*lp, &*dp}) {
      EvaluationOptions o;
      o.keep_samples = true;
      auto e = EvaluateTrajectory(**model, *pieces, o);
      uint64_t h = 1469598103934665603ull;
      for (const auto& s : e->samples) h = Fnv(Fnv(h, s.risk.risk), s.arc_length_m);
      std::printf("eval %-14s risk %a len %a adm %d samples %zu hash %016" PRIx64 "\n", sc.name,
                  e->risk, e->length_m, e->admissible ? 1 : 0, e->samples.size(), h);
    }
    if (only_eval) continue;
    for (const Algo& al : algos) {
      auto planner = MakePlanner(al.a);
      PlanningProblem problem{*model, sc.start, sc.goal};
      PlanOptions opt;
      opt.budget.max_time_s = 0.0;
      opt.budget.max_iterations = al.iters;
      opt.seed = 7;
      CancellationToken cancel;
      int improvements = 0;
      auto r =
          (*planner)->Plan(problem, opt, cancel, [&](const PlanImprovement&) { ++improvements; });
      if (!r.ok()) {
        std::printf("plan %-14s %-13s error %s\n", sc.name, al.name,
                    std::string(r.status().message()).c_str());
        continue;
      }
      uint64_t h = 1469598103934665603ull;
      double risk = -1, len = -1;
      size_t n = 0;
      if (r->best) {
        risk = r->best->risk;
        len = r->best->length_m;
        n = r->best->waypoints.size();
        for (const Pose& p : r->best->waypoints) h = Fnv(Fnv(Fnv(Fnv(h, p.x), p.y), p.z), p.theta);
      }
      std::printf("plan %-14s %-13s %s risk %a len %a wps %zu impr %d iters %" PRId64
                  " cfg %" PRIu64 " hash %016" PRIx64 "\n",
                  sc.name, al.name, std::string(StopReasonName(r->reason)).c_str(), risk, len, n,
                  improvements, r->iterations, r->configurations_evaluated, h);
      std::fflush(stdout);
    }
  }
  return 0;
}
}  // namespace
}  // namespace riskplan
int main(int argc, char** argv) {
  riskplan::cmdline::ParseCommandLine(
      argc, argv,
      {.program = "riskplan-bench-fingerprint",
       .usage = "every planner's final trajectory and EvaluateTrajectory on the demo-city "
                "scenarios as exact bits, to diff before and after a change that must not "
                "change them.\n"
                "\n"
                "  riskplan-bench-fingerprint [--eval_only] > fingerprint.txt"});
  return riskplan::Main();
}
