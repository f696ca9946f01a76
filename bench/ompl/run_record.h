// One benchmark run of the OMPL peer benchmark and the lines it is reported
// as. The report is plain CSV on stdout, one record per line, first field the
// kind (bench/ompl/plot_ompl_bench.py reads it):
//   imp,planner,scenario,seed,elapsed_s,risk,iterations      one per improvement
//   chk,planner,scenario,seed,budget_s,iterations            iterations by a budget
//   run,planner,scenario,seed,budget_s,solved,elapsed_s,iterations,vertices,
//       best_risk,reevaluated_risk,reevaluated_admissible,configurations
// Risks are printed with 17 significant digits (exact doubles).
#ifndef RISKPLAN_BENCH_OMPL_RUN_RECORD_H_
#define RISKPLAN_BENCH_OMPL_RUN_RECORD_H_

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

namespace riskplan::bench {

struct RunImprovement {
  double elapsed_s = 0.0;
  double risk = 0.0;
  int64_t iterations = 0;
};

struct RunRecord {
  std::string planner;
  std::string scenario;
  uint64_t seed = 0;
  double budget_s = 0.0;
  std::vector<RunImprovement> improvements;  // in order of time
  // (budget_s, iterations completed when the clock passed it).
  std::vector<std::pair<double, int64_t>> checkpoint_iterations;
  bool solved = false;
  double elapsed_s = 0.0;
  int64_t iterations = 0;
  int64_t vertices = 0;
  double best_risk = std::nan("");
  // The final trajectory's risk and admissibility by EvaluateTrajectory.
  double reevaluated_risk = std::nan("");
  bool reevaluated_admissible = false;
  uint64_t configurations = 0;  // configuration risks computed
};

inline void PrintRecord(const RunRecord& r) {
  const char* p = r.planner.c_str();
  const char* s = r.scenario.c_str();
  const auto seed = static_cast<unsigned long long>(r.seed);
  for (const RunImprovement& i : r.improvements) {
    std::printf("imp,%s,%s,%llu,%.6f,%.17g,%lld\n", p, s, seed, i.elapsed_s, i.risk,
                static_cast<long long>(i.iterations));
  }
  for (const auto& [budget, iterations] : r.checkpoint_iterations) {
    std::printf("chk,%s,%s,%llu,%g,%lld\n", p, s, seed, budget, static_cast<long long>(iterations));
  }
  std::printf("run,%s,%s,%llu,%g,%d,%.6f,%lld,%lld,%.17g,%.17g,%d,%llu\n", p, s, seed, r.budget_s,
              r.solved ? 1 : 0, r.elapsed_s, static_cast<long long>(r.iterations),
              static_cast<long long>(r.vertices), r.best_risk, r.reevaluated_risk,
              r.reevaluated_admissible ? 1 : 0, static_cast<unsigned long long>(r.configurations));
  std::fflush(stdout);
}

}  // namespace riskplan::bench

#endif  // RISKPLAN_BENCH_OMPL_RUN_RECORD_H_
