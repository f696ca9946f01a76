// The verilated component against the software model of the datapath
// (ModelDevice), bit for bit, on thousands of distinct random kernels of
// every side from 1 to 63 (the largest a weight slot holds) in both
// configurations, and on windows at the map's border.
#include <algorithm>
#include <cmath>
#include <memory>
#include <set>
#include <utility>
#include <vector>

#include "accel/blobs.h"
#include "accel/fixed_point.h"
#include "accel/shim/device.h"
#include "accel/shim/mmio_device.h"
#include "core/base/random.h"
#include "gtest/gtest.h"
#include "tests/rtl/rtl_test_util.h"

namespace riskplan::accel {
namespace {

using testing::ExpectSameAsModel;
using testing::Fixture;

// A table of height bins with the given half-widths and `headings` heading
// bins, every kernel's weights of one of several kinds: normalised, raw
// uniform in [0, 1] (the largest products), sparse, a few units of the
// last place (2^-W), weights of exactly 1 (saturate to 2^W - 1) among
// random ones, or all equal to a random value.
QuantizedKernelTable RandomKernels(const NumberFormat& format, const std::vector<int>& half_widths,
                                   int headings, uint64_t seed) {
  Rng rng(seed);
  KernelSet set;
  set.height_bins = static_cast<int>(half_widths.size());
  set.heading_bins = headings;
  set.half_width = half_widths;
  const double ulp = std::ldexp(1.0, -format.weight_frac_bits);
  for (int b = 1; b <= set.height_bins; ++b) {
    const size_t cells =
        static_cast<size_t>(2 * half_widths[b - 1] + 1) * (2 * half_widths[b - 1] + 1);
    for (int k = 0; k < headings; ++k) {
      std::vector<double> w(cells);
      double sum = 0;
      switch (rng.Below(6)) {
        case 0:
          for (double& x : w) sum += (x = rng.Uniform());
          for (double& x : w) x /= sum;
          break;
        case 1:
          for (double& x : w) x = rng.Uniform();
          break;
        case 2:
          for (double& x : w) x = rng.Uniform() < 0.9 ? 0.0 : rng.Uniform();
          break;
        case 3:
          for (double& x : w) x = static_cast<double>(rng.Below(5)) * ulp;
          break;
        case 4:
          for (double& x : w) x = rng.Uniform() < 0.1 ? 1.0 : rng.Uniform();
          break;
        default: {
          const double c = rng.Uniform();
          for (double& x : w) x = c;
          break;
        }
      }
      set.weights.push_back(std::move(w));
    }
  }
  auto kernels = QuantizeKernelsBlob(EncodeKernelsBlob(set), format, 63);
  EXPECT_TRUE(kernels.ok()) << kernels.status();
  QuantizedKernelTable table = kernels.ok() ? *std::move(kernels) : QuantizedKernelTable{};
  table.id = seed;
  return table;
}

// Kernels whose quantised weights differ from every other's.
size_t DistinctKernels(const QuantizedKernelTable& table) {
  std::set<std::vector<uint64_t>> seen;
  for (const QuantizedKernel& k : table.kernels) seen.insert(k.weights);
  return seen.size();
}

// A random map of nx x ny cells (a fifth empty, the rest over four orders
// of magnitude, some at the largest density), quantised with `pad`.
QuantizedMap RandomMap(const NumberFormat& format, int nx, int ny, int pad, uint64_t seed) {
  Rng rng(seed);
  std::vector<float> density(nx * ny), shelter(nx * ny);
  for (int c = 0; c < nx * ny; ++c) {
    const double r = rng.Uniform();
    density[c] = r < 0.2 ? 0.0f : r < 0.25 ? 0.0589f : static_cast<float>(0.06 * rng.Uniform());
    shelter[c] = static_cast<float>(rng.Uniform() < 0.1 ? 10.0 : 10.0 * rng.Uniform());
  }
  return QuantizeMap(nx, ny, density.data(), shelter.data(), format, pad);
}

// Every kernel of the table `per_kernel` times, in a random order, in
// groups of 1 to 8 sites a few cells apart (so jobs mix kernels and slots
// are replaced), a group's centre anywhere within reach of the map.
std::vector<DeviceSite> SitesForEveryKernel(const QuantizedKernelTable& table, int nx, int ny,
                                            int per_kernel, uint64_t seed) {
  Rng rng(seed);
  std::vector<std::pair<uint16_t, uint16_t>> order;
  for (int r = 0; r < per_kernel; ++r) {
    for (int b = 1; b <= table.height_bins; ++b) {
      for (int k = 0; k < table.heading_bins; ++k) order.emplace_back(b, k);
    }
  }
  for (size_t n = order.size(); n > 1; --n) std::swap(order[n - 1], order[rng.Below(n)]);
  std::vector<DeviceSite> sites;
  size_t next = 0;
  while (next < order.size()) {
    const int ci = -20 + static_cast<int>(rng.Below(nx + 40));
    const int cj = -20 + static_cast<int>(rng.Below(ny + 40));
    for (size_t g = 1 + rng.Below(8); g > 0 && next < order.size(); --g, ++next) {
      sites.push_back({order[next].first, order[next].second,
                       ci + static_cast<int>(rng.Below(7)) - 3,
                       cj + static_cast<int>(rng.Below(7)) - 3});
    }
  }
  return sites;
}

TEST(RtlRandomKernelsTest, BoardBuildMatchesTheModelOnThousandsOfRandomKernels) {
  // 64 height bins of half-widths 0 to 31, each twice (sides 1 to 63, the
  // largest a slot holds), x 32 headings: 2,048 kernels, each at 2 sites,
  // through 4 weight slots.
  std::vector<int> half_widths;
  for (int r = 0; r < 2; ++r) {
    for (int hw = 0; hw <= 31; ++hw) half_widths.push_back(hw);
  }
  Fixture f;
  f.map = RandomMap(NumberFormat::Board(), 160, 120, 40, 61);
  f.kernels = RandomKernels(NumberFormat::Board(), half_widths, 32, 62);
  ASSERT_EQ(f.kernels.kernels.size(), 2048u);
  EXPECT_GE(DistinctKernels(f.kernels), 2000u);
  f.sites = SitesForEveryKernel(f.kernels, 160, 120, 2, 63);
  ExpectSameAsModel("l8-board", f);
}

TEST(RtlRandomKernelsTest, PreciseBuildMatchesTheModelOnAThousandRandomKernels) {
  // 32 height bins of half-widths 0 to 31 x 32 headings: 1,024 kernels of
  // two-word weights and cells, each at 2 sites, through 8 slots, 16 lanes.
  std::vector<int> half_widths;
  for (int hw = 0; hw <= 31; ++hw) half_widths.push_back(hw);
  Fixture f;
  f.map = RandomMap(NumberFormat::Precise(), 140, 110, 40, 71);
  f.kernels = RandomKernels(NumberFormat::Precise(), half_widths, 32, 72);
  ASSERT_EQ(f.kernels.kernels.size(), 1024u);
  EXPECT_GE(DistinctKernels(f.kernels), 1000u);
  f.sites = SitesForEveryKernel(f.kernels, 140, 110, 2, 73);
  ExpectSameAsModel("l16-precise", f);
}

TEST(RtlRandomKernelsTest, WindowsAtTheMapBorderMatchTheModel) {
  // The border is the host's business: MmioDevice streams every cell of a
  // cut, reading off-map cells as the quantised 0 and 10 (QuantizedMap::
  // DensityAt, ShelterAt) as ModelEwmm does, so the RTL never sees an edge.
  // Windows centred from beyond to inside each edge and corner of a map
  // with a pad of 4 cells (so they end in the pad, beyond it, or wholly off
  // the map), on a full and a random density layer.
  const std::vector<int> half_widths = {0, 3, 10, 31};
  for (const bool full : {true, false}) {
    Fixture f;
    constexpr int kNx = 50, kNy = 40;
    if (full) {
      std::vector<float> density(kNx * kNy, 0.0589f), shelter(kNx * kNy, 4.0f);
      f.map = QuantizeMap(kNx, kNy, density.data(), shelter.data(), NumberFormat::Board(), 4);
    } else {
      f.map = RandomMap(NumberFormat::Board(), kNx, kNy, 4, 81);
    }
    f.kernels = RandomKernels(NumberFormat::Board(), half_widths, 2, 82 + full);
    std::vector<bool> off_map;
    for (uint16_t b = 1; b <= half_widths.size(); ++b) {
      const int hw = half_widths[b - 1];
      // Centres from hw + 2 cells outside to hw cells inside an edge.
      for (int d = -hw - 2; d <= hw; ++d) {
        const int mid_i = kNx / 2, mid_j = kNy / 2;
        const DeviceSite at[] = {{b, 0, d, mid_j},       {b, 1, kNx - 1 - d, mid_j},
                                 {b, 0, mid_i, d},       {b, 1, mid_i, kNy - 1 - d},
                                 {b, 0, d, d},           {b, 1, kNx - 1 - d, kNy - 1 - d},
                                 {b, 0, d, kNy - 1 - d}, {b, 1, kNx - 1 - d, d}};
        for (const DeviceSite& s : at) {
          f.sites.push_back(s);
          off_map.push_back(s.impact_i + hw < 0 || s.impact_j + hw < 0 || s.impact_i - hw >= kNx ||
                            s.impact_j - hw >= kNy);
        }
      }
    }
    ExpectSameAsModel("l8-board", f);
    // A window wholly off the map sums density 0 (the model's sums, equal
    // to the RTL's as checked above).
    ModelDevice model(NumberFormat::Board());
    std::vector<Accumulator> impact(f.sites.size()), shelter(f.sites.size());
    uint64_t cycles = 0;
    ASSERT_TRUE(model.Evaluate(f.map, f.kernels, f.sites, impact, shelter, &cycles).ok());
    int wholly_off = 0;
    for (size_t s = 0; s < f.sites.size(); ++s) {
      if (!off_map[s]) continue;
      ++wholly_off;
      EXPECT_EQ(impact[s], 0) << "site " << s;
    }
    EXPECT_GT(wholly_off, 0);
  }
}

}  // namespace
}  // namespace riskplan::accel
