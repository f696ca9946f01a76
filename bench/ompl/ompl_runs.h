// Runs one of OMPL 1.5's optimal planners on one riskplan problem, for the
// OMPL peer benchmark: the space, checkers and objective of risk_state_space.h
// and risk_objective.h, a wall-time budget, the intermediate-solution
// callback recording the anytime curve, and an independent re-evaluation of
// the final path with EvaluateTrajectory.
//
// OMPL's RNG takes its seed once per process (ompl::RNG::setSeed is ignored
// after the first generator exists), so RunOmplPlanner must be the first
// thing in its process that touches OMPL's random numbers: the benchmark runs
// each (planner, scenario, seed) in a fresh child process.
#ifndef RISKPLAN_BENCH_OMPL_OMPL_RUNS_H_
#define RISKPLAN_BENCH_OMPL_OMPL_RUNS_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "bench/ompl/run_record.h"
#include "bench/scenarios.h"
#include "core/risk/risk_model.h"

namespace riskplan::bench {

// Planner settings (reported with the results; docs/benchmarks.md says how
// they were tuned).
struct OmplSettings {
  // RRT* and Informed RRT*.
  double rrt_range_m = 400.0;      // longest extension; also caps the radius rule
  double rrt_rewire_factor = 1.1;  // OMPL's default
  bool rrt_k_nearest = true;       // OMPL's default
  double rrt_goal_bias = 0.05;     // OMPL's default (RISK_RRT_STAR: 0.05 too)
  std::string rrt_nn = "grid";     // grid | sqrtapprox | linear
  double grid_cell_m = 200.0;      // cell of the grid structure
  // Informed RRT*'s pruning measures a vertex's cost-to-come by motionCost
  // from the start straight to it when this is true (OMPL's choice): not a
  // lower bound for risk, and a full edge evaluation per vertex per pruning.
  bool irrt_admissible_cost_to_come = false;
  // BIT*.
  unsigned bit_samples_per_batch = 100;  // OMPL's default
  double bit_rewire_factor = 1.1;        // OMPL's default
  bool bit_k_nearest = true;             // OMPL's default
  // ABIT* (a BIT* subclass): samples per batch, rewire factor and the
  // k-nearest rule are BIT*'s settings above; these three are its own.
  double abit_initial_inflation = 1e6;  // OMPL's default
  double abit_inflation_scaling = 10;   // OMPL's default
  double abit_truncation_scaling = 5;   // OMPL's default
};

// "RRTstar", "InformedRRTstar", "BITstar", "ABITstar".
bool IsOmplPlanner(const std::string& name);

// Plans start -> goal of `scenario` with `planner` for `budget_s` of wall
// time, after ompl::RNG::setSeed(seed). The clock starts after setup(), as
// RISK_RRT_STAR's starts after its checks. `checkpoints_s` (ascending, each
// <= budget_s) are the times at which the iteration count is recorded.
// InvalidArgument for an unknown planner or setting. With the environment
// variable RISKPLAN_OMPL_DEBUG set, also prints the number of motionCost
// calls, configuration risks and motion checks to stderr.
absl::StatusOr<RunRecord> RunOmplPlanner(const std::string& planner,
                                         std::shared_ptr<const RiskModel> model,
                                         const Scenario& scenario, uint64_t seed, double budget_s,
                                         const std::vector<double>& checkpoints_s,
                                         const OmplSettings& settings);

}  // namespace riskplan::bench

#endif  // RISKPLAN_BENCH_OMPL_OMPL_RUNS_H_
