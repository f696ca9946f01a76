// Configuration-risk throughput of the CPU kernel (RiskModel::Evaluate) on
// demo-city at 100 m above ground, for the two access patterns of issue 5:
// samples along trajectories (neighbours 5 m apart, as the planner asks) and
// random configurations across the map.
#include <memory>
#include <vector>

#include "benchmark/benchmark.h"
#include "core/demo_city.h"
#include "core/random.h"
#include "core/risk_model.h"

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
Pose At100mAgl(const RiskModel& model, double x, double y, double theta) {
  int i = 0;
  int j = 0;
  model.map().CellOf(x, y, &i, &j);
  return Pose{x, y, model.map().terrain(i, j) + 100.0, theta};
}

std::vector<Pose> AlongTrajectories(size_t n) {
  const RiskModel& model = Model();
  Rng rng(1);
  std::vector<Pose> out;
  while (out.size() < n) {
    // A straight 1 km leg in a random direction, sampled every 5 m.
    const double theta = rng.Uniform() * 6.283185307179586;
    double x = 1000.0 + rng.Uniform() * 6000.0;
    double y = 1000.0 + rng.Uniform() * 6000.0;
    for (int k = 0; k < 200 && out.size() < n; ++k) {
      out.push_back(At100mAgl(model, x, y, theta));
      x += 5.0 * std::cos(theta);
      y += 5.0 * std::sin(theta);
    }
  }
  return out;
}

std::vector<Pose> RandomConfigurations(size_t n) {
  const RiskModel& model = Model();
  Rng rng(2);
  std::vector<Pose> out;
  for (size_t k = 0; k < n; ++k) {
    out.push_back(At100mAgl(model, 200.0 + rng.Uniform() * 7600.0, 200.0 + rng.Uniform() * 7600.0,
                            rng.Uniform() * 6.283185307179586));
  }
  return out;
}

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
