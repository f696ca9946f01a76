// The CPU kernel's float32 path against the exact definition: within 1e-5
// relative on M (the spec's bound for a documented float32 path) on
// thousands of random and along-trajectory demo-city configurations, on
// every instruction set, in any visiting order, with and without the site
// cache; and its weights cache, bounded and never mixed with exact results.
#include "accel/float_kernel.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <tuple>
#include <vector>

#include "accel/cpu_kernel.h"
#include "accel/kernel_weights.h"
#include "accel/risk_engine.h"
#include "accel_test_util.h"
#include "core/map/demo_city.h"
#include "gtest/gtest.h"

namespace riskplan::accel {
namespace {

using testing::MixedConfigs;
using testing::SameRisk;
using testing::SmallCity;

// The bounds docs/risk-model.md derives ("The float32 path"): the sums to
// (kFlushRows + 6) * 2^-24 relative, M to 1e-5.
constexpr double kSumBound = (kFlushRows + 6) * 0x1p-24;
constexpr double kRiskBound = 1e-5;

// demo-city at its full 8 km (the benchmarks' map), default parameters.
const RiskModel& DemoCity() {
  static const std::shared_ptr<const RiskModel> model = [] {
    auto map = MakeDemoCity();
    EXPECT_TRUE(map.ok()) << map.status();
    auto m = RiskModel::Create(*map, ModelParams{});
    EXPECT_TRUE(m.ok()) << m.status();
    return *m;
  }();
  return *model;
}

Pose AtAgl(const RiskModel& model, double x, double y, double agl, double theta) {
  int i = 0;
  int j = 0;
  model.map().CellOf(x, y, &i, &j);
  return Pose{x, y, model.map().terrain(i, j) + agl, theta};
}

// Legs of 200 samples 5 m apart, and uniform configurations, at `agl` m
// (0: 30 to 150 m, the planner's band) with random headings.
std::vector<Pose> AlongTrajectories(const RiskModel& model, size_t n, double agl, uint64_t seed) {
  Rng rng(seed);
  std::vector<Pose> out;
  while (out.size() < n) {
    const double theta = rng.Uniform() * kTwoPi;
    const double height = agl > 0 ? agl : 30.0 + 120.0 * rng.Uniform();
    double x = 1000.0 + rng.Uniform() * 6000.0;
    double y = 1000.0 + rng.Uniform() * 6000.0;
    for (int k = 0; k < 200 && out.size() < n; ++k) {
      out.push_back(AtAgl(model, x, y, height, theta));
      x += 5.0 * std::cos(theta);
      y += 5.0 * std::sin(theta);
    }
  }
  return out;
}

std::vector<Pose> RandomConfigurations(const RiskModel& model, size_t n, double agl,
                                       uint64_t seed) {
  Rng rng(seed);
  std::vector<Pose> out;
  for (size_t k = 0; k < n; ++k) {
    const double height = agl > 0 ? agl : 30.0 + 120.0 * rng.Uniform();
    out.push_back(AtAgl(model, 200.0 + rng.Uniform() * 7600.0, 200.0 + rng.Uniform() * 7600.0,
                        height, rng.Uniform() * kTwoPi));
  }
  return out;
}

double RelativeError(double got, double want) {
  if (want == 0.0) return got == 0.0 ? 0.0 : 1.0;
  return std::abs(got / want - 1.0);
}

struct Errors {
  double risk = 0.0;
  double impact = 0.0;
  double shelter = 0.0;
  size_t compared = 0;
};

// Evaluates `configs` in batches of `batch` and checks every result against
// RiskModel::Evaluate; returns the largest errors.
Errors ExpectWithinBound(const RiskModel& model, CpuRiskKernel& kernel,
                         const std::vector<Pose>& configs, size_t batch) {
  std::vector<ConfigurationRisk> out(configs.size());
  for (size_t first = 0; first < configs.size(); first += batch) {
    const size_t count = std::min(batch, configs.size() - first);
    kernel.Evaluate(model, std::span<const Pose>(configs).subspan(first, count),
                    std::span<ConfigurationRisk>(out).subspan(first, count));
  }
  Errors e;
  int bad = 0;
  for (size_t n = 0; n < configs.size() && bad < 5; ++n) {
    const ConfigurationRisk want = model.Evaluate(configs[n]);
    const ConfigurationRisk& got = out[n];
    const double risk = RelativeError(got.risk, want.risk);
    const double impact = RelativeError(got.impact_factor, want.impact_factor);
    const double shelter = RelativeError(got.expected_shelter, want.expected_shelter);
    const bool ok = got.defined == want.defined && got.height_bin == want.height_bin &&
                    got.heading_bin == want.heading_bin &&
                    got.exposed_area_m2 == want.exposed_area_m2 && risk <= kRiskBound &&
                    impact <= kSumBound && shelter <= kSumBound;
    if (!ok) {
      ++bad;
      ADD_FAILURE() << "configuration " << n << " (" << configs[n].x << ", " << configs[n].y << ", "
                    << configs[n].z << ", " << configs[n].theta << "): risk " << got.risk << " vs "
                    << want.risk << " (" << risk << "), I " << impact << ", S~ " << shelter;
    }
    if (want.defined) ++e.compared;
    e.risk = std::max(e.risk, risk);
    e.impact = std::max(e.impact, impact);
    e.shelter = std::max(e.shelter, shelter);
  }
  return e;
}

// (instruction set, site cache, batch size)
class Float32PathTest : public ::testing::TestWithParam<std::tuple<Isa, bool, int>> {};

TEST_P(Float32PathTest, WithinTheSpecBoundOfTheExactPath) {
  const auto [isa, cached, batch] = GetParam();
  if (static_cast<int>(isa) > static_cast<int>(CpuRiskKernel::BestIsa())) {
    GTEST_SKIP() << "instruction set not available on this machine";
  }
  const RiskModel& model = DemoCity();
  PreparedMapCache maps(size_t{1} << 30);
  KernelWeightsCache weights(size_t{1} << 30);
  SiteCache cache(cached ? size_t{16} << 20 : 0);
  CpuKernelOptions options;
  options.isa = isa;
  options.precision = KernelPrecision::kFloat32;
  CpuRiskKernel kernel(&maps, &cache, options, &weights);
  ASSERT_EQ(kernel.isa(), isa);
  ASSERT_EQ(kernel.precision(), KernelPrecision::kFloat32);
  // 100 m above ground (the benchmarks' 21 x 21 kernels) and the planner's
  // whole band (kernels of other widths).
  const std::vector<std::pair<const char*, std::vector<Pose>>> sets = {
      {"along, 100 m", AlongTrajectories(model, 4000, 100.0, 1)},
      {"random, 100 m", RandomConfigurations(model, 4000, 100.0, 2)},
      {"along, 30-150 m", AlongTrajectories(model, 2000, 0.0, 3)},
      {"random, 30-150 m", RandomConfigurations(model, 2000, 0.0, 4)},
  };
  for (const auto& [name, configs] : sets) {
    const Errors e = ExpectWithinBound(model, kernel, configs, static_cast<size_t>(batch));
    EXPECT_GT(e.compared, configs.size() * 9 / 10) << name;
    std::printf("isa %d, %s, batch %d%s: largest relative error M %.3g, I %.3g, S~ %.3g\n",
                static_cast<int>(isa), name, batch, cached ? ", site cache" : "", e.risk, e.impact,
                e.shelter);
  }
  if (cached) {
    // Again, now from the site cache: the same bound.
    ExpectWithinBound(model, kernel, sets[0].second, static_cast<size_t>(batch));
    EXPECT_GT(kernel.stats().cache_hits, 3000u);
  }
}

INSTANTIATE_TEST_SUITE_P(AllPaths, Float32PathTest,
                         ::testing::Combine(::testing::Values(Isa::kPortable, Isa::kAvx2,
                                                              Isa::kAvx512),
                                            ::testing::Bool(), ::testing::Values(256, 5000)));

TEST(Float32PathTest, WithinTheSpecBoundInWind) {
  const RiskModel& model = *testing::SmallCityInWind();
  PreparedMapCache maps(size_t{1} << 30);
  KernelWeightsCache weights(size_t{1} << 30);
  CpuKernelOptions options;
  options.precision = KernelPrecision::kFloat32;
  CpuRiskKernel kernel(&maps, nullptr, options, &weights);
  const std::vector<Pose> configs = MixedConfigs(model, 8000, 5);
  const Errors e = ExpectWithinBound(model, kernel, configs, 256);
  std::printf("in wind: %zu compared, largest relative error M %.3g\n", e.compared, e.risk);
  EXPECT_GT(e.compared, configs.size() / 4);
}

TEST(Float32PathTest, AwkwardAndMixedConfigurations) {
  // Undefined configurations, windows off the map, headings far beyond 2 pi,
  // heights above the table, on the small city.
  const RiskModel& model = *SmallCity();
  const RiskMap& m = model.map();
  std::vector<Pose> configs = MixedConfigs(model, 6000, 17);
  const double z = m.terrain(300, 300) + 100.0;
  for (const Pose& q : std::vector<Pose>{
           {m.x0() + 1500.0, m.y0() + 1500.0, z, 1e12},
           {m.x0() + 1500.0, m.y0() + 1500.0, z, -7.0},
           {m.x0(), m.y0(), m.terrain(0, 0) + 50.0, 1.0},
           {m.x0() + 100.0, m.y0() + 100.0, m.terrain(20, 20) + 1e-9, 1.0},
           {m.x0() + 100.0, m.y0() + 100.0, m.terrain(20, 20) + 5000.0, 1.0},
           {m.x0() + 2.0, m.y0() + 2990.0, m.terrain(0, 598) + 290.0, 2.5},
       }) {
    configs.push_back(q);
  }
  for (Isa isa : {Isa::kPortable, Isa::kAvx2, Isa::kAvx512}) {
    if (static_cast<int>(isa) > static_cast<int>(CpuRiskKernel::BestIsa())) continue;
    PreparedMapCache maps(size_t{1} << 30);
    KernelWeightsCache weights(size_t{1} << 30);
    CpuKernelOptions options;
    options.isa = isa;
    options.precision = KernelPrecision::kFloat32;
    options.sort_min_configs = 64;
    CpuRiskKernel kernel(&maps, nullptr, options, &weights);
    ExpectWithinBound(model, kernel, configs, configs.size());
    ExpectWithinBound(model, kernel, configs, 300);
  }
}

TEST(Float32PathTest, SameBitsWhateverTheBatchAndGrouping) {
  // A window's sums do not depend on the windows computed beside it (groups
  // of 1, 2 or 4, sorted or not), so a float32 plan is reproducible on the
  // same instruction set.
  const RiskModel& model = *SmallCity();
  const std::vector<Pose> configs = MixedConfigs(model, 3000, 31);
  for (Isa isa : {Isa::kPortable, Isa::kAvx2, Isa::kAvx512}) {
    if (static_cast<int>(isa) > static_cast<int>(CpuRiskKernel::BestIsa())) continue;
    PreparedMapCache maps(size_t{1} << 30);
    KernelWeightsCache weights(size_t{1} << 30);
    CpuKernelOptions options;
    options.isa = isa;
    options.precision = KernelPrecision::kFloat32;
    options.sort_min_configs = 64;
    CpuRiskKernel kernel(&maps, nullptr, options, &weights);
    std::vector<ConfigurationRisk> whole(configs.size());
    kernel.Evaluate(model, configs, whole);
    for (size_t n = 0; n < configs.size(); n += 7) {
      ConfigurationRisk one;
      kernel.Evaluate(model, std::span<const Pose>(&configs[n], 1), std::span(&one, 1));
      ASSERT_TRUE(SameRisk(one, whole[n])) << "isa " << static_cast<int>(isa) << ", " << n;
    }
  }
}

TEST(Float32PathTest, ExactAndFloat32NeverShareSiteCacheEntries) {
  const RiskModel& model = *SmallCity();
  PreparedMapCache maps(size_t{1} << 30);
  KernelWeightsCache weights(size_t{1} << 30);
  SiteCache cache(size_t{4} << 20);
  CpuKernelOptions options;
  options.precision = KernelPrecision::kFloat32;
  CpuRiskKernel float32(&maps, &cache, options, &weights);
  CpuRiskKernel exact(&maps, &cache, {}, &weights);
  const std::vector<Pose> configs = MixedConfigs(model, 5000, 23);
  std::vector<ConfigurationRisk> out(configs.size());
  float32.Evaluate(model, configs, out);  // fills the cache with float32 results
  exact.Evaluate(model, configs, out);
  EXPECT_EQ(exact.stats().cache_hits, 0u);
  for (size_t n = 0; n < configs.size(); ++n) {
    ASSERT_TRUE(SameRisk(out[n], model.Evaluate(configs[n]))) << n;
  }
  exact.Evaluate(model, configs, out);  // now from its own entries
  EXPECT_GT(exact.stats().cache_hits, 3000u);
  for (size_t n = 0; n < configs.size(); ++n) {
    ASSERT_TRUE(SameRisk(out[n], model.Evaluate(configs[n]))) << n;
  }
}

TEST(Float32PathTest, WithoutRoomForFloat32WeightsItComputesExactly) {
  const RiskModel& model = *SmallCity();
  PreparedMapCache maps(size_t{1} << 30);
  KernelWeightsCache none(1000);
  CpuKernelOptions options;
  options.precision = KernelPrecision::kFloat32;
  CpuRiskKernel kernel(&maps, nullptr, options, &none);
  const std::vector<Pose> configs = MixedConfigs(model, 2000, 29);
  std::vector<ConfigurationRisk> out(configs.size());
  kernel.Evaluate(model, configs, out);
  for (size_t n = 0; n < configs.size(); ++n) {
    ASSERT_TRUE(SameRisk(out[n], model.Evaluate(configs[n]))) << n;
  }
  EXPECT_EQ(none.MemoryBytes(), 0u);
}

TEST(KernelWeightsTest, AlignedCopiesOfTheTable) {
  const RiskModel& model = *SmallCity();
  const ImpactTable& table = model.table();
  KernelWeightsCache cache(size_t{1} << 30);
  auto exact = cache.Get(model.table_ptr(), WeightFormat::kDouble);
  auto single = cache.Get(model.table_ptr(), WeightFormat::kFloat32);
  ASSERT_NE(exact, nullptr);
  ASSERT_NE(single, nullptr);
  EXPECT_EQ(cache.Get(model.table_ptr(), WeightFormat::kDouble), exact);
  EXPECT_EQ(cache.MemoryBytes(), KernelWeights::BytesFor(table, WeightFormat::kDouble) +
                                     KernelWeights::BytesFor(table, WeightFormat::kFloat32));
  for (int b = 1; b <= table.height_bins(); b += 7) {
    for (int k = 0; k < table.heading_bins(); k += 5) {
      const ImpactKernel& kernel = table.kernel(b, k);
      const int side = kernel.Side();
      const int stride = KernelWeights::StrideFor(side, WeightFormat::kFloat32);
      const double* d = exact->doubles(b, k);
      const float* f = single->floats(b, k);
      for (int v = 0; v < side; ++v) {
        EXPECT_EQ(reinterpret_cast<uintptr_t>(d + v * kernel.Stride()) % 64, 0u);
        EXPECT_EQ(reinterpret_cast<uintptr_t>(f + v * stride) % 64, 0u);
        for (int u = 0; u < stride; ++u) {
          const double w = u < kernel.Stride() ? kernel.weights[v * kernel.Stride() + u] : 0.0;
          if (u < kernel.Stride()) {
            ASSERT_EQ(d[v * kernel.Stride() + u], w);
          }
          ASSERT_EQ(f[v * stride + u], u < side ? static_cast<float>(w) : 0.0f);
        }
      }
    }
  }
}

TEST(KernelWeightsTest, BoundedAndNeverKeepsATableAlive) {
  std::weak_ptr<const ImpactTable> weak;
  const size_t one = KernelWeights::BytesFor(SmallCity()->table(), WeightFormat::kFloat32);
  KernelWeightsCache cache(one);
  {
    ModelParams params;
    params.failure_rate_per_s = 1e-7;  // the same kernels, another table
    auto table = *ImpactTable::Build(params, SmallCity()->map().res());
    weak = table;
    EXPECT_NE(cache.Get(table, WeightFormat::kFloat32), nullptr);
    EXPECT_EQ(cache.MemoryBytes(), one);
  }
  EXPECT_TRUE(weak.expired());
  // Room for one: the next table's copy replaces the first.
  EXPECT_NE(cache.Get(SmallCity()->table_ptr(), WeightFormat::kFloat32), nullptr);
  EXPECT_EQ(cache.MemoryBytes(), one);
  KernelWeightsCache none(1000);
  EXPECT_EQ(none.Get(SmallCity()->table_ptr(), WeightFormat::kDouble), nullptr);
}

TEST(Float32PathTest, ThroughTheEngine) {
  const RiskModel& model = DemoCity();
  RiskEngineOptions options;
  options.cpu_workers = 1;
  options.kernel.precision = KernelPrecision::kFloat32;
  auto engine = RiskEngine::Create(options);
  ASSERT_TRUE(engine.ok()) << engine.status();
  const std::vector<Pose> configs = RandomConfigurations(model, 20000, 100.0, 7);
  std::vector<ConfigurationRisk> out(configs.size());
  ASSERT_TRUE((*engine)->Evaluate(model, configs, out).ok());
  for (size_t n = 0; n < configs.size(); ++n) {
    const ConfigurationRisk want = model.Evaluate(configs[n]);
    ASSERT_EQ(out[n].defined, want.defined) << n;
    ASSERT_LE(RelativeError(out[n].risk, want.risk), kRiskBound) << n;
  }
  const RiskEngineStats stats = (*engine)->Stats();
  EXPECT_EQ(stats.kernel_weights_bytes,
            KernelWeights::BytesFor(model.table(), WeightFormat::kFloat32));
}

TEST(KernelPrecisionTest, Names) {
  KernelPrecision p = KernelPrecision::kExact;
  EXPECT_TRUE(ParseKernelPrecision("float32", &p));
  EXPECT_EQ(p, KernelPrecision::kFloat32);
  EXPECT_EQ(KernelPrecisionName(p), "float32");
  EXPECT_TRUE(ParseKernelPrecision("exact", &p));
  EXPECT_EQ(p, KernelPrecision::kExact);
  EXPECT_EQ(KernelPrecisionName(p), "exact");
  EXPECT_FALSE(ParseKernelPrecision("float16", &p));
}

}  // namespace
}  // namespace riskplan::accel
