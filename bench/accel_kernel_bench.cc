// Configuration risks per second on one core: the core's RiskModel::Evaluate
// against accel's CpuRiskKernel, exact (bit for bit the same results) and
// its float32 path (within 1e-5 relative; checked here too), on demo-city
// at 100 m above ground, for the two access patterns of issue 5:
//   Along:  samples along 1 km straight legs, 5 m apart (as the planner asks);
//   Random: configurations uniformly across the map, random headings.
// Batch sizes: the kernel is handed `batch` configurations at a time (the
// planner's batches are a few hundred; EvaluateRisk's and the engine's chunks
// up to tens of thousands). Run side by side in one process so that the
// machine's load affects both alike; quote medians of repetitions.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <vector>

#include "accel/cpu_kernel.h"
#include "accel/prepared_map.h"
#include "accel/risk_engine.h"
#include "bench/scenarios.h"
#include "benchmark/benchmark.h"
#include "core/base/random.h"
#include "core/map/demo_city.h"
#include "core/planners/planner.h"
#include "core/risk/risk_model.h"

namespace riskplan {
namespace {

const std::shared_ptr<const RiskModel>& ModelPtr() {
  static const std::shared_ptr<const RiskModel> model = [] {
    auto map = MakeDemoCity();
    return *RiskModel::Create(*map, ModelParams{});
  }();
  return model;
}

const RiskModel& Model() { return *ModelPtr(); }

Pose At100mAgl(const RiskModel& model, double x, double y, double theta) {
  int i = 0;
  int j = 0;
  model.map().CellOf(x, y, &i, &j);
  return Pose{x, y, model.map().terrain(i, j) + 100.0, theta};
}

// The same generators as bench/risk_kernel_bench.cc.
std::vector<Pose> AlongTrajectories(size_t n) {
  const RiskModel& model = Model();
  Rng rng(1);
  std::vector<Pose> out;
  while (out.size() < n) {
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

const std::vector<Pose>& Along() {
  static const std::vector<Pose> configs = AlongTrajectories(100000);
  return configs;
}
const std::vector<Pose>& Random() {
  static const std::vector<Pose> configs = RandomConfigurations(100000);
  return configs;
}

accel::PreparedMapCache& Maps() {
  static accel::PreparedMapCache maps(size_t{1} << 30);
  return maps;
}

// Aborts unless the kernel gives RiskModel::Evaluate's results bit for bit.
void CheckExact(const std::vector<Pose>& configs) {
  const RiskModel& model = Model();
  accel::CpuRiskKernel kernel(&Maps(), nullptr);
  std::vector<ConfigurationRisk> out(configs.size());
  kernel.Evaluate(model, configs, out);
  for (size_t n = 0; n < configs.size(); ++n) {
    const ConfigurationRisk want = model.Evaluate(configs[n]);
    if (want.defined != out[n].defined || want.risk != out[n].risk ||
        want.impact_factor != out[n].impact_factor ||
        want.expected_shelter != out[n].expected_shelter) {
      std::fprintf(stderr, "kernel differs from RiskModel::Evaluate at %zu\n", n);
      std::abort();
    }
  }
}

void RunCore(benchmark::State& state, const std::vector<Pose>& configs) {
  const RiskModel& model = Model();
  double sink = 0.0;
  for (auto _ : state) {
    for (const Pose& q : configs) sink += model.Evaluate(q).risk;
  }
  benchmark::DoNotOptimize(sink);
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * configs.size()));
}

accel::KernelWeightsCache& Weights() {
  static accel::KernelWeightsCache weights(size_t{1} << 30);
  return weights;
}

// Aborts unless the float32 path is within 1e-5 relative of
// RiskModel::Evaluate on every configuration; prints the largest error.
void CheckFloat32(const char* name, const std::vector<Pose>& configs) {
  const RiskModel& model = Model();
  for (accel::Isa isa : {accel::Isa::kPortable, accel::Isa::kAvx2, accel::Isa::kAvx512}) {
    accel::CpuKernelOptions options;
    options.isa = isa;
    options.precision = accel::KernelPrecision::kFloat32;
    accel::CpuRiskKernel kernel(&Maps(), nullptr, options, &Weights());
    if (kernel.isa() != isa) continue;
    std::vector<ConfigurationRisk> out(configs.size());
    kernel.Evaluate(model, configs, out);
    double worst = 0.0;
    for (size_t n = 0; n < configs.size(); ++n) {
      const ConfigurationRisk want = model.Evaluate(configs[n]);
      const double error =
          want.risk == 0.0 ? std::abs(out[n].risk) : std::abs(out[n].risk / want.risk - 1.0);
      if (want.defined != out[n].defined || !(error <= 1e-5)) {
        std::fprintf(stderr, "float32 path off by %g relative at %zu\n", error, n);
        std::abort();
      }
      worst = std::max(worst, error);
    }
    std::fprintf(stderr, "float32 path, %s, isa %d: largest relative error of M %.3g\n", name,
                 static_cast<int>(isa), worst);
  }
  std::fprintf(stderr, "float32 weights of the table: %zu bytes\n", Weights().MemoryBytes());
}

// Args: batch size, instruction set (0 portable, 1 AVX2, 2 AVX-512),
// precision (0 exact, 1 float32).
// `warm`: the first batch over and over (its map footprint stays in the
// caches: the arithmetic's ceiling) instead of walking through all configs.
void RunKernel(benchmark::State& state, const std::vector<Pose>& configs, bool prepared,
               bool warm = false) {
  static bool checked = [] {
    CheckExact(Along());
    CheckExact(Random());
    CheckFloat32("along", Along());
    CheckFloat32("random", Random());
    return true;
  }();
  benchmark::DoNotOptimize(checked);
  const RiskModel& model = Model();
  const size_t batch = static_cast<size_t>(state.range(0));
  accel::PreparedMapCache no_maps(0);
  accel::CpuKernelOptions options;
  options.isa = static_cast<accel::Isa>(state.range(1));
  options.precision = static_cast<accel::KernelPrecision>(state.range(2));
  accel::CpuRiskKernel kernel(prepared ? &Maps() : &no_maps, nullptr, options, &Weights());
  if (kernel.isa() != options.isa) {
    state.SkipWithError("instruction set not available");
    return;
  }
  std::vector<ConfigurationRisk> out(batch);
  double sink = 0.0;
  for (auto _ : state) {
    for (size_t first = 0; first + batch <= configs.size(); first += batch) {
      kernel.Evaluate(model, std::span<const Pose>(configs).subspan(warm ? 0 : first, batch), out);
      sink += out[0].risk;
    }
  }
  benchmark::DoNotOptimize(sink);
  state.SetItemsProcessed(
      static_cast<int64_t>(state.iterations() * (configs.size() / batch * batch)));
  // Sites equal to the one before them (computed once, copied).
  state.counters["repeat_share"] = static_cast<double>(kernel.stats().repeats) /
                                   static_cast<double>(kernel.stats().configurations);
}

void BM_Core_Along(benchmark::State& state) { RunCore(state, Along()); }
void BM_Core_Random(benchmark::State& state) { RunCore(state, Random()); }
void BM_Kernel_Along(benchmark::State& state) { RunKernel(state, Along(), true); }
void BM_Kernel_Random(benchmark::State& state) { RunKernel(state, Random(), true); }
// Without PreparedMap: the map's own layers (4 KiB pages).
void BM_KernelWarm_Along(benchmark::State& state) { RunKernel(state, Along(), true, true); }
void BM_KernelUnprepared_Along(benchmark::State& state) { RunKernel(state, Along(), false); }
void BM_KernelUnprepared_Random(benchmark::State& state) { RunKernel(state, Random(), false); }

// The hit path of the site cache: every site of the batch is in the cache
// (the second and later passes over the same configurations).
void BM_KernelCacheHits_Along(benchmark::State& state) {
  const std::vector<Pose>& configs = Along();
  accel::SiteCache cache(size_t{256} << 20);
  accel::CpuRiskKernel kernel(&Maps(), &cache);
  std::vector<ConfigurationRisk> out(4096);
  const auto pass = [&] {
    for (size_t first = 0; first + 4096 <= configs.size(); first += 4096) {
      kernel.Evaluate(Model(), std::span<const Pose>(configs).subspan(first, 4096), out);
    }
  };
  pass();  // fills the cache
  for (auto _ : state) pass();
  state.SetItemsProcessed(
      static_cast<int64_t>(state.iterations() * (configs.size() / 4096 * 4096)));
}

// Risk-based RRT* on demo-city scenarios, 800 iterations each, evaluating
// directly (core) or through a RiskEngine on the calling thread, with and
// without the site cache (Arg: site cache MiB). Reports the share of sites
// the cache answered.
void BM_Planner(benchmark::State& state, bool engine_path) {
  const std::shared_ptr<const RiskModel>& model = ModelPtr();
  const std::vector<bench::Scenario> scenarios = bench::DemoCityScenarios(*model);
  accel::RiskEngineOptions options;
  options.cpu_workers = 0;
  options.site_cache_bytes = static_cast<size_t>(state.range(0)) << 20;
  std::unique_ptr<accel::RiskEngine> engine = *accel::RiskEngine::Create(options);
  uint64_t configurations = 0;
  for (auto _ : state) {
    for (size_t s = 0; s < scenarios.size(); s += 6) {
      PlanningProblem problem{model, scenarios[s].start, scenarios[s].goal};
      PlanOptions plan;
      plan.budget.max_time_s = 0.0;
      plan.budget.max_iterations = 800;
      plan.seed = 3;
      CancellationToken cancel;
      std::unique_ptr<RiskEvaluator> evaluator = engine_path ? engine->NewEvaluator() : nullptr;
      auto planner = *MakePlanner(PlannerAlgorithm::kRiskRrtStar, evaluator.get());
      auto result = planner->Plan(problem, plan, cancel, nullptr);
      configurations += result->configurations_evaluated;
    }
  }
  state.SetItemsProcessed(static_cast<int64_t>(configurations));
  const accel::RiskEngineStats stats = engine->Stats();
  if (stats.cache_hits + stats.cache_misses > 0) {
    state.counters["cache_hit_share"] = static_cast<double>(stats.cache_hits) /
                                        static_cast<double>(stats.cache_hits + stats.cache_misses);
  }
}
void BM_Planner_Direct(benchmark::State& state) { BM_Planner(state, false); }
void BM_Planner_Engine(benchmark::State& state) { BM_Planner(state, true); }

BENCHMARK(BM_Core_Along)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_KernelCacheHits_Along)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Planner_Direct)->Arg(0)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Planner_Engine)->Arg(0)->Arg(64)->Unit(benchmark::kMillisecond);
// Exact and float32 side by side, by batch size; the portable float32
// fallback at one size.
BENCHMARK(BM_Kernel_Along)
    ->ArgsProduct({{256, 1024, 4096, 100000}, {1, 2}, {0, 1}})
    ->Args({4096, 0, 1})
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_KernelWarm_Along)
    ->ArgsProduct({{256, 4096}, {2}, {0, 1}})
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_KernelUnprepared_Along)
    ->ArgsProduct({{100000}, {1, 2}, {0}})
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Core_Random)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Kernel_Random)
    ->ArgsProduct({{256, 1024, 4096, 100000}, {1, 2}, {0, 1}})
    ->Args({4096, 0, 1})
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_KernelUnprepared_Random)
    ->ArgsProduct({{100000}, {1, 2}, {0}})
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace riskplan

BENCHMARK_MAIN();
