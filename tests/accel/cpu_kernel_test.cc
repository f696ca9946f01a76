// The CPU workers' kernel gives RiskModel::Evaluate's results bit for bit,
// on every instruction set, with and without its caches, in any visiting
// order, and on the awkward configurations.
#include "accel/cpu_kernel.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>
#include <vector>

#include "accel_test_util.h"
#include "gtest/gtest.h"

namespace riskplan::accel {
namespace {

using testing::MixedConfigs;
using testing::SameRisk;
using testing::SmallCity;

void ExpectExact(const RiskModel& model, CpuRiskKernel& kernel, const std::vector<Pose>& configs) {
  std::vector<ConfigurationRisk> out(configs.size());
  kernel.Evaluate(model, configs, out);
  int bad = 0;
  for (size_t n = 0; n < configs.size() && bad < 5; ++n) {
    const ConfigurationRisk want = model.Evaluate(configs[n]);
    if (!SameRisk(out[n], want)) {
      ++bad;
      ADD_FAILURE() << "configuration " << n << " (" << configs[n].x << ", " << configs[n].y << ", "
                    << configs[n].z << ", " << configs[n].theta << "): risk " << out[n].risk
                    << " vs " << want.risk;
    }
  }
}

// Consecutive configurations with the same kernel site (the same impact
// cell and bins: samples of a trajectory closer than a cell, or the same pose
// twice) are computed once and copied; every result is still exact, whatever
// the precision, and only equal sites are copied.
TEST(CpuKernelTest, RepeatedSitesAreComputedOnceWithTheSameResults) {
  const RiskModel& model = *SmallCity();
  std::vector<Pose> configs;
  for (const Pose& q : MixedConfigs(model, 3000, 41)) {
    configs.push_back(q);
    // The same pose, and a pose 1 cm away (nearly always the same site).
    configs.push_back(q);
    configs.push_back(Pose{q.x + 0.01, q.y, q.z, q.theta});
  }
  CpuRiskKernel kernel(nullptr, nullptr);
  ExpectExact(model, kernel, configs);
  EXPECT_GT(kernel.stats().repeats, 5000u);
  EXPECT_EQ(kernel.stats().ewmms + kernel.stats().repeats,
            static_cast<uint64_t>(std::count_if(configs.begin(), configs.end(), [&](const Pose& q) {
              KernelSite site;
              return model.Locate(q, &site);
            })));
  // Samples 5 m apart along legs rarely repeat a site, and never wrongly.
  CpuRiskKernel along(nullptr, nullptr);
  ExpectExact(model, along, MixedConfigs(model, 20000, 42));
  EXPECT_LT(along.stats().repeats, 2000u);
}

// (instruction set, prepared maps and aligned weights, site cache, sort
// threshold)
class CpuKernelExactTest : public ::testing::TestWithParam<std::tuple<Isa, bool, bool, int>> {};

TEST_P(CpuKernelExactTest, MatchesRiskModelBitForBit) {
  const auto [isa, prepared, cached, sort_min] = GetParam();
  if (static_cast<int>(isa) > static_cast<int>(CpuRiskKernel::BestIsa())) {
    GTEST_SKIP() << "instruction set not available on this machine";
  }
  const RiskModel& model = *SmallCity();
  PreparedMapCache maps(prepared ? size_t{1} << 30 : 0);
  KernelWeightsCache weights(prepared ? size_t{1} << 30 : 0);
  SiteCache cache(cached ? size_t{1} << 20 : 0);
  CpuKernelOptions options;
  options.isa = isa;
  options.sort_min_configs = sort_min;
  CpuRiskKernel kernel(&maps, &cache, options, &weights);
  ASSERT_EQ(kernel.isa(), isa);
  const std::vector<Pose> configs = MixedConfigs(model, 20000, 11);
  ExpectExact(model, kernel, configs);
  // Again: now partly from the site cache.
  ExpectExact(model, kernel, configs);
  if (cached) {
    EXPECT_GT(kernel.stats().cache_hits, 10000u);
  }
  // Small batches (the planner's), scattered ones, single configurations.
  for (size_t first = 0; first + 300 <= 3000; first += 300) {
    ExpectExact(model, kernel,
                std::vector<Pose>(configs.begin() + first, configs.begin() + first + 300));
  }
  ExpectExact(model, kernel, {configs[5]});
}

INSTANTIATE_TEST_SUITE_P(
    AllPaths, CpuKernelExactTest,
    ::testing::Combine(::testing::Values(Isa::kPortable, Isa::kAvx2, Isa::kAvx512),
                       ::testing::Bool(), ::testing::Bool(), ::testing::Values(0, 64)));

// In wind every path locates by the air heading and finishes with the (b, k)
// entry's energy: still RiskModel::Evaluate's results, bit for bit.
TEST(CpuKernelTest, MatchesRiskModelBitForBitInWind) {
  const RiskModel& model = *testing::SmallCityInWind();
  ASSERT_FALSE(model.wind().calm());
  const std::vector<Pose> configs = MixedConfigs(model, 20000, 17);
  for (Isa isa : {Isa::kPortable, Isa::kAvx2, Isa::kAvx512}) {
    if (static_cast<int>(isa) > static_cast<int>(CpuRiskKernel::BestIsa())) continue;
    for (bool cached : {false, true}) {
      PreparedMapCache maps(size_t{1} << 30);
      KernelWeightsCache weights(size_t{1} << 30);
      SiteCache cache(cached ? size_t{1} << 20 : 0);
      CpuKernelOptions options;
      options.isa = isa;
      CpuRiskKernel kernel(&maps, &cache, options, &weights);
      ExpectExact(model, kernel, configs);
      // The still-air model's results through the same caches stay its own.
      ExpectExact(*SmallCity(), kernel, configs);
      ExpectExact(model, kernel, configs);
    }
  }
  // And the wind changes the answers: same poses, other risks.
  int differ = 0;
  for (size_t n = 0; n < 2000; ++n) {
    const ConfigurationRisk a = model.Evaluate(configs[n]);
    const ConfigurationRisk b = SmallCity()->Evaluate(configs[n]);
    if (a.defined && b.defined && a.risk != b.risk) ++differ;
  }
  EXPECT_GT(differ, 500);
}

TEST(CpuKernelTest, AwkwardConfigurations) {
  const RiskModel& model = *SmallCity();
  const RiskMap& m = model.map();
  const double inf = std::numeric_limits<double>::infinity();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double z = m.terrain(300, 300) + 100.0;
  std::vector<Pose> configs = {
      {m.x0() + 1500.0, m.y0() + 1500.0, z, 0.0},
      {m.x0() + 1500.0, m.y0() + 1500.0, z, kTwoPi},
      {m.x0() + 1500.0, m.y0() + 1500.0, z, -1e-300},
      {m.x0() + 1500.0, m.y0() + 1500.0, z, -7.0},
      {m.x0() + 1500.0, m.y0() + 1500.0, z, 1e12},  // quotient beyond 31 bits
      {m.x0() + 1500.0, m.y0() + 1500.0, z, -1e15},
      {m.x0() + 1500.0, m.y0() + 1500.0, z, 0.0436332312998582},  // a bin edge
      {m.x0() + 1500.0, m.y0() + 1500.0, z, nan},
      {m.x0() + 1500.0, m.y0() + 1500.0, inf, 0.0},
      {m.x0(), m.y0(), m.terrain(0, 0) + 50.0, 1.0},      // the corner cell
      {m.x0() + m.width_m(), m.y0() + 10.0, 300.0, 1.0},  // just outside
      {std::nextafter(m.x0() + m.width_m(), 0.0), m.y0() + 10.0, 300.0, 3.0},
      {m.x0() + 5.0 * 17, m.y0() + 5.0 * 23, m.terrain(17, 23) + 30.0, 4.0},  // cell edges
      {m.x0() + 100.0, m.y0() + 100.0, m.terrain(20, 20), 1.0},               // h = 0
      {m.x0() + 100.0, m.y0() + 100.0, m.terrain(20, 20) + 1e-9, 1.0},        // tiny h
      {m.x0() + 100.0, m.y0() + 100.0, m.terrain(20, 20) + 5000.0, 1.0},      // above the table
      {m.x0() + 2.0, m.y0() + 2990.0, m.terrain(0, 598) + 290.0, 2.5},        // window off the map
  };
  for (Isa isa : {Isa::kPortable, Isa::kAvx2, Isa::kAvx512}) {
    if (static_cast<int>(isa) > static_cast<int>(CpuRiskKernel::BestIsa())) continue;
    PreparedMapCache maps(size_t{1} << 30);
    KernelWeightsCache weights(size_t{1} << 30);
    CpuKernelOptions options;
    options.isa = isa;
    CpuRiskKernel kernel(&maps, nullptr, options, &weights);
    ExpectExact(model, kernel, configs);
  }
}

TEST(CpuKernelTest, WideKernelsTakeTheFallback) {
  // 1 m cells: kernels reach the largest half width allowed (here 40, a side
  // of 81 cells, wider than the vector loops).
  MapHeader header;
  header.name = "fine";
  header.res = 1.0;
  header.nx = 300;
  header.ny = 200;
  MapLayers layers;
  Rng rng(3);
  for (int c = 0; c < 300 * 200; ++c) {
    layers.density.push_back(static_cast<float>(0.01 * rng.Uniform()));
    layers.shelter.push_back(static_cast<float>(10.0 * rng.Uniform()));
    layers.terrain.push_back(100.0f);
    layers.nofly.push_back(0);
  }
  auto map = RiskMap::Create(header, layers);
  ASSERT_TRUE(map.ok()) << map.status();
  ModelParams params;
  params.max_half_width = 40;
  auto model = RiskModel::Create(*map, params);
  ASSERT_TRUE(model.ok()) << model.status();
  std::vector<Pose> configs;
  for (int k = 0; k < 400; ++k) {
    configs.push_back({300.0 * rng.Uniform(), 200.0 * rng.Uniform(), 100.0 + 290.0 * rng.Uniform(),
                       kTwoPi * rng.Uniform()});
  }
  PreparedMapCache maps(size_t{1} << 30);
  KernelWeightsCache weights(size_t{1} << 30);
  CpuRiskKernel kernel(&maps, nullptr, {}, &weights);
  ExpectExact(**model, kernel, configs);
}

// Any site Locate can give: every height and heading bin, impact cells
// anywhere their windows stay inside the map (spec version 2).
TEST(CpuKernelTest, SumsMatchEwmmForAnySite) {
  const RiskModel& model = *SmallCity();
  PreparedMapCache maps(size_t{1} << 30);
  KernelWeightsCache weights(size_t{1} << 30);
  CpuRiskKernel kernel(&maps, nullptr, {}, &weights);
  Rng rng(5);
  std::vector<LocatedSite> sites;
  int drawn = 0;
  while (sites.size() < 5000) {
    LocatedSite s;
    s.site = {1 + static_cast<int>(rng.Uniform() * 60), static_cast<int>(rng.Uniform() * 72),
              -150 + static_cast<int>(rng.Uniform() * 900),
              -150 + static_cast<int>(rng.Uniform() * 900)};
    ++drawn;
    if (!model.WindowInsideMap(s.site)) continue;
    s.index = static_cast<uint32_t>(sites.size());
    sites.push_back(s);
  }
  ASSERT_GT(drawn, 5000);  // some windows reached past the map and were left out
  std::vector<double> impact(sites.size()), shelter(sites.size());
  kernel.Sums(model, sites, impact, shelter);
  for (size_t n = 0; n < sites.size(); ++n) {
    const KernelSite& s = sites[n].site;
    double i = 0, sh = 0;
    model.Ewmm(model.table().kernel(s.height_bin, s.heading_bin), s.impact_i, s.impact_j, &i, &sh);
    ASSERT_EQ(impact[n], i) << n;
    ASSERT_EQ(shelter[n], sh) << n;
  }
}

TEST(PreparedMapCacheTest, BoundedAndNeverKeepsAMapAlive) {
  std::weak_ptr<const RiskMap> weak;
  PreparedMapCache maps(size_t{64} << 20);
  {
    auto map = testing::SmallCity()->map_ptr();
    EXPECT_NE(maps.Get(map), nullptr);
    EXPECT_EQ(maps.Get(map), maps.Get(map));
    EXPECT_EQ(maps.MemoryBytes(), PreparedMap::BytesFor(*map));
  }
  PreparedMapCache none(1000);
  EXPECT_EQ(none.Get(testing::SmallCity()->map_ptr()), nullptr);
}

}  // namespace
}  // namespace riskplan::accel
