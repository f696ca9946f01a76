// What the planner benchmarks that run plans on the demo-city scenarios share
// (riskplan-bench-planner, riskplan-bench-compare, and the CPU clock of
// riskplan-bench-seeds and riskplan-bench-shared-tree): the model and the
// chosen scenarios, planner parameters from a flag, medians and the thread's
// CPU time.
#ifndef RISKPLAN_BENCH_PLANNER_RUNS_H_
#define RISKPLAN_BENCH_PLANNER_RUNS_H_

#include <time.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/str_split.h"
#include "absl/strings/string_view.h"
#include "bench/scenarios.h"
#include "core/map/demo_city.h"
#include "core/planners/cost_to_go_field.h"
#include "core/planners/planner.h"
#include "core/planners/planner_support.h"
#include "core/risk/risk_model.h"

namespace riskplan::bench {

// The median of `v`; NaN when it is empty.
inline double Median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// CPU time of the calling thread: a planner runs on it, so rates per CPU
// second stay meaningful on a loaded machine, where wall-time rates do not.
inline double ThreadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// Planner parameters from "name=value,...". An item without exactly one '='
// is skipped, as the benchmarks always have.
inline std::map<std::string, double> ParsePlannerParams(absl::string_view text) {
  std::map<std::string, double> params;
  for (absl::string_view kv : absl::StrSplit(text, ',', absl::SkipEmpty())) {
    std::vector<std::string> parts = absl::StrSplit(kv, '=');
    if (parts.size() == 2) params[parts[0]] = std::stod(parts[1]);
  }
  return params;
}

// The guide field's lattice that RISK_RRT_STAR builds for `params` (its
// guide_field_* parameters, the planner's defaults for those not given).
inline LatticeOptions GuideFieldOptions(const std::map<std::string, double>& params) {
  std::map<std::string, double> field;
  for (const char* name :
       {"guide_field_m", "guide_field_step_m", "guide_field_headings", "guide_field_levels"}) {
    if (auto it = params.find(name); it != params.end()) field[name] = it->second;
  }
  absl::StatusOr<PlannerParamValues> v = PlannerParamValues::Parse(
      "RISK_RRT_STAR", PlannerParams(PlannerAlgorithm::kRiskRrtStar), field);
  if (!v.ok()) return GuideLatticeOptions(400.0, 25.0);
  return GuideLatticeOptions(v->Get("guide_field_m"), v->Get("guide_field_step_m"),
                             static_cast<int>(v->Get("guide_field_headings")),
                             static_cast<int>(v->Get("guide_field_levels")));
}

// The demo-city model (default parameters) and its scenarios, only those named
// in `wanted` (comma-separated; empty: all), in the set's order.
struct DemoCityRuns {
  std::shared_ptr<const RiskModel> model;
  std::vector<Scenario> scenarios;
};

inline absl::StatusOr<DemoCityRuns> LoadDemoCityRuns(absl::string_view wanted) {
  auto map = MakeDemoCity();
  if (!map.ok()) return map.status();
  auto model = RiskModel::Create(*map, ModelParams{});
  if (!model.ok()) return model.status();
  DemoCityRuns runs{*model, DemoCityScenarios(**model)};
  if (!wanted.empty()) {
    std::vector<std::string> names = absl::StrSplit(wanted, ',');
    std::erase_if(runs.scenarios, [&](const Scenario& s) {
      return std::find(names.begin(), names.end(), s.name) == names.end();
    });
  }
  return runs;
}

}  // namespace riskplan::bench

#endif  // RISKPLAN_BENCH_PLANNER_RUNS_H_
