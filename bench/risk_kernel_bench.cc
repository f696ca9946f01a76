// Configuration-risk throughput of the CPU kernel (RiskModel::Evaluate) on
// demo-city at 100 m above ground, for the two access patterns of issue 5:
// samples along trajectories (neighbours 5 m apart, as the planner asks) and
// random configurations across the map.
#include <memory>
#include <vector>

#include "bench/demo_city_configs.h"
#include "benchmark/benchmark.h"
#include "core/map/demo_city.h"
#include "core/risk/risk_model.h"

namespace riskplan {
namespace {

const RiskModel& Model() {
  static std::shared_ptr<const RiskModel> model = [] {
    auto map = MakeDemoCity();
    return *RiskModel::Create(*map, ModelParams{});
  }();
  return *model;
}

// Configurations 100 m above the terrain at (x, y).
std::vector<Pose> AlongTrajectories(size_t n) { return bench::AlongTrajectories(Model(), n); }
std::vector<Pose> RandomConfigurations(size_t n) { return bench::RandomConfigurations(Model(), n); }

void Run(benchmark::State& state, const std::vector<Pose>& configs) {
  const RiskModel& model = Model();
  double sink = 0.0;
  for (auto _ : state) {
    for (const Pose& q : configs) sink += model.Evaluate(q).risk;
  }
  benchmark::DoNotOptimize(sink);
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * configs.size()));
}

void BM_ConfigurationRisk_AlongTrajectories(benchmark::State& state) {
  static const std::vector<Pose> configs = AlongTrajectories(100000);
  Run(state, configs);
}
BENCHMARK(BM_ConfigurationRisk_AlongTrajectories)->Unit(benchmark::kMillisecond);

void BM_ConfigurationRisk_Random(benchmark::State& state) {
  static const std::vector<Pose> configs = RandomConfigurations(100000);
  Run(state, configs);
}
BENCHMARK(BM_ConfigurationRisk_Random)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace riskplan

BENCHMARK_MAIN();
