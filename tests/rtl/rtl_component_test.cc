// The RTL of the streaming EWMM component (accel/rtl/rp_ewmm.sv) under
// Verilator, driven through its registers and stream sink by the shim's
// MmioDevice, against the software model of the datapath (ModelDevice): the
// same sums bit for bit on thousands of random sites (and some 250 kernels;
// rtl_random_kernels_test.cc has thousands), with the edge cases (windows
// across and beyond the map border, an empty density layer, the largest
// kernel, weights that saturate), the same cycle counts as the
// register-level ComponentModel, exact cycle counts, and the same answers to
// bad jobs.
#include <algorithm>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "accel/blobs.h"
#include "accel/fixed_point.h"
#include "accel/rtl/verilated_component.h"
#include "accel/shim/component_model.h"
#include "accel/shim/component_regs.h"
#include "accel/shim/device.h"
#include "accel/shim/mmio_device.h"
#include "core/base/random.h"
#include "gtest/gtest.h"
#include "tests/rtl/rtl_test_util.h"

namespace riskplan::accel {
namespace {

using testing::ExpectSameAsModel;
using testing::Fixture;
using testing::OpenRtl;

enum class Density { kRandom, kEmpty, kFull };

// A random map of nx x ny cells, a random kernel table whose height bins have
// half-widths `half_widths` (31 is the largest kernel, 63 x 63), and sites:
// legs of neighbours one cell apart (as along a trajectory) and scattered ones,
// a fifth of them on or beyond the map's border.
Fixture MakeFixture(const NumberFormat& format, Density density_kind,
                    const std::vector<int>& half_widths, int sites, uint64_t seed) {
  Rng rng(seed);
  const int nx = 40 + static_cast<int>(rng.Uniform() * 60);
  const int ny = 30 + static_cast<int>(rng.Uniform() * 60);
  std::vector<float> density(nx * ny), shelter(nx * ny);
  for (int c = 0; c < nx * ny; ++c) {
    switch (density_kind) {
      case Density::kRandom:
        // Some empty cells, the rest spread over four orders of magnitude.
        density[c] = rng.Uniform() < 0.2 ? 0.0f : static_cast<float>(0.06 * rng.Uniform());
        break;
      case Density::kEmpty:
        density[c] = 0.0f;
        break;
      case Density::kFull:
        density[c] = 0.0589f;
        break;
    }
    shelter[c] = static_cast<float>(rng.Uniform() < 0.1 ? 10.0 : 10.0 * rng.Uniform());
  }
  Fixture f;
  f.map = QuantizeMap(nx, ny, density.data(), shelter.data(), format, 40);
  KernelSet set;
  set.height_bins = static_cast<int>(half_widths.size());
  set.heading_bins = 3;
  set.half_width = half_widths;
  for (int b = 1; b <= set.height_bins; ++b) {
    const int side = 2 * half_widths[b - 1] + 1;
    for (int k = 0; k < set.heading_bins; ++k) {
      std::vector<double> w(side * side);
      if (k == 0 && b == 1) {
        // One weight of 1 (saturates to 2^W - 1), the rest 0.
        w[static_cast<size_t>(rng.Uniform() * w.size())] = 1.0;
      } else {
        double sum = 0;
        for (double& x : w) sum += (x = rng.Uniform() < 0.05 ? 0.0 : rng.Uniform());
        for (double& x : w) x /= sum;
      }
      set.weights.push_back(w);
    }
  }
  auto kernels = QuantizeKernelsBlob(EncodeKernelsBlob(set), format, 63);
  EXPECT_TRUE(kernels.ok()) << kernels.status();
  f.kernels = *std::move(kernels);
  f.kernels.id = seed + 1;
  const auto random_kernel = [&] {
    return std::pair<uint16_t, uint16_t>(1 + static_cast<uint16_t>(rng.Uniform() * set.height_bins),
                                         static_cast<uint16_t>(rng.Uniform() * set.heading_bins));
  };
  while (static_cast<int>(f.sites.size()) < sites) {
    const auto [b, k] = random_kernel();
    const int hw = half_widths[b - 1];
    const double r = rng.Uniform();
    if (r < 0.2) {
      // On or beyond the border: the window partly or wholly off the map.
      const int i = rng.Uniform() < 0.5 ? -hw - 1 + static_cast<int>(rng.Uniform() * (2 * hw + 2))
                                        : nx - hw + static_cast<int>(rng.Uniform() * (2 * hw + 2));
      const int j = -hw - 1 + static_cast<int>(rng.Uniform() * (ny + 2 * hw + 2));
      f.sites.push_back({b, k, rng.Uniform() < 0.5 ? i : j % nx, rng.Uniform() < 0.5 ? j : i % ny});
    } else if (r < 0.5) {
      f.sites.push_back(
          {b, k, static_cast<int>(rng.Uniform() * nx), static_cast<int>(rng.Uniform() * ny)});
    } else {
      int i = static_cast<int>(rng.Uniform() * nx), j = static_cast<int>(rng.Uniform() * ny);
      const int di = rng.Uniform() < 0.5 ? 1 : 0, dj = rng.Uniform() < 0.5 ? 1 : -1;
      for (int s = 0; s < 12 && static_cast<int>(f.sites.size()) < sites; ++s) {
        f.sites.push_back({b, k, i += di, j += dj});
      }
    }
  }
  return f;
}

TEST(RtlComponentTest, ConfigurationsMatchTheVerilatedParameters) {
  for (const RtlConfig& config : VerilatedConfigs()) {
    auto bus = OpenVerilatedComponent(config.name);
    ASSERT_TRUE(bus.ok()) << bus.status();
    RegisterBus& b = **bus;
    EXPECT_EQ(b.Read32(regs::kId), regs::kIdValue) << config.name;
    EXPECT_EQ(b.Read32(regs::kVersion), regs::kVersionValue);
    const uint32_t caps = b.Read32(regs::kCaps);
    EXPECT_EQ(caps & 0xff, config.lanes) << config.name;
    EXPECT_EQ(static_cast<int>((caps >> 8) & 0xff), config.format.weight_frac_bits);
    EXPECT_EQ(static_cast<int>((caps >> 16) & 0xff), config.format.cell_bits);
    EXPECT_EQ(static_cast<int>(caps >> 24), config.format.acc_bits);
    const uint32_t limits = b.Read32(regs::kLimits);
    EXPECT_EQ(limits & 0xffff, config.max_side);
    EXPECT_EQ(limits >> 16, config.weight_slots);
    EXPECT_EQ(b.Read32(regs::kClockHz), config.clock_hz);
    EXPECT_EQ(b.Read32(regs::kStatus), 0u);
    EXPECT_EQ(b.Name(), "verilator:" + config.name);
  }
  EXPECT_EQ(OpenVerilatedComponent("no-such").status().code(), absl::StatusCode::kNotFound);
}

// Five height bins of random half-widths (0 to 20) and three headings each.
std::vector<int> RandomHalfWidths(uint64_t seed) {
  Rng rng(seed * 7919);
  std::vector<int> half_widths(5);
  for (int& hw : half_widths) hw = static_cast<int>(rng.Uniform() * 21);
  return half_widths;
}

TEST(RtlComponentTest, BoardBuildMatchesTheModelOnRandomSitesAndKernels) {
  // 10 maps and kernel tables (150 kernels), 4,000 sites.
  for (uint64_t seed = 1; seed <= 10; ++seed) {
    ExpectSameAsModel("l8-board", MakeFixture(NumberFormat::Board(), Density::kRandom,
                                              RandomHalfWidths(seed), 400, seed));
  }
}

TEST(RtlComponentTest, PreciseBuildMatchesTheModelOnRandomSitesAndKernels) {
  // Two stream words per value, 128-bit accumulators, 16 lanes.
  // 5 maps and kernel tables (75 kernels), 2,000 sites.
  for (uint64_t seed = 11; seed <= 15; ++seed) {
    ExpectSameAsModel("l16-precise", MakeFixture(NumberFormat::Precise(), Density::kRandom,
                                                 RandomHalfWidths(seed), 400, seed));
  }
}

TEST(RtlComponentTest, LargestKernelAndOneCellKernel) {
  ExpectSameAsModel("l8-board",
                    MakeFixture(NumberFormat::Board(), Density::kRandom, {31, 0}, 120, 21));
  ExpectSameAsModel("l16-precise",
                    MakeFixture(NumberFormat::Precise(), Density::kFull, {31}, 40, 22));
}

TEST(RtlComponentTest, EmptyAndFullDensityLayers) {
  const Fixture empty = MakeFixture(NumberFormat::Board(), Density::kEmpty, {3, 10}, 300, 31);
  ExpectSameAsModel("l8-board", empty);
  ExpectSameAsModel("l8-board",
                    MakeFixture(NumberFormat::Board(), Density::kFull, {3, 10}, 300, 32));
}

TEST(RtlComponentTest, FewerLanesGiveTheSameSums) {
  const Fixture f = MakeFixture(NumberFormat::Precise(), Density::kRandom, {4, 10}, 300, 41);
  for (uint32_t lanes : {1u, 3u, 16u}) ExpectSameAsModel("l16-precise", f, lanes);
}

// Drives the same register sequence into the RTL and the ComponentModel and
// compares what they show.
class Both {
 public:
  Both() {
    auto bus = OpenVerilatedComponent("l8-board");
    EXPECT_TRUE(bus.ok());
    rtl_ = *std::move(bus);
    ComponentConfig cc;
    cc.lanes = 8;
    cc.weight_slots = 4;
    model_ = std::make_unique<ComponentModel>(cc);
  }
  void Write(uint32_t offset, uint32_t value) {
    rtl_->Write32(offset, value);
    model_->Write32(offset, value);
  }
  // STATUS of both, after the RTL's pipeline has drained.
  uint32_t Status() {
    for (int i = 0; i < 8; ++i) rtl_->Read32(regs::kId);
    const uint32_t r = rtl_->Read32(regs::kStatus);
    EXPECT_EQ(r, model_->Read32(regs::kStatus));
    return r;
  }
  uint32_t Read(uint32_t offset) {
    const uint32_t r = rtl_->Read32(offset);
    EXPECT_EQ(r, model_->Read32(offset)) << "offset 0x" << std::hex << offset;
    return r;
  }
  void Lane(uint32_t l, uint32_t slot, uint32_t side, uint32_t col, uint32_t row) {
    Write(regs::LaneReg(l, regs::kLaneSlot), slot);
    Write(regs::LaneReg(l, regs::kLaneSide), side);
    Write(regs::LaneReg(l, regs::kLaneCol), col);
    Write(regs::LaneReg(l, regs::kLaneRow), row);
  }

 private:
  std::unique_ptr<SimulatedComponentBus> rtl_;
  std::unique_ptr<ComponentModel> model_;
};

uint32_t ErrorOf(uint32_t status) {
  return (status & regs::kStatusError) ? (status >> 8) & 0xff : 0;
}

TEST(RtlComponentTest, RefusesBadJobsAsTheModelDoes) {
  Both both;
  both.Write(regs::kCutCols, 10);
  both.Write(regs::kCutRows, 10);
  // A window past the cut's right edge.
  both.Lane(0, 0, 5, 6, 0);
  both.Write(regs::kLaneMask, 1);
  both.Write(regs::kCtrl, regs::kCtrlStart);
  EXPECT_EQ(ErrorOf(both.Status()), regs::kErrorBadLane);
  // A slot the component does not have; a side of 0; a side above 63.
  both.Lane(0, 4, 5, 0, 0);
  both.Write(regs::kCtrl, regs::kCtrlStart);
  EXPECT_EQ(ErrorOf(both.Status()), regs::kErrorBadLane);
  both.Lane(0, 0, 0, 0, 0);
  both.Write(regs::kCtrl, regs::kCtrlStart);
  EXPECT_EQ(ErrorOf(both.Status()), regs::kErrorBadLane);
  both.Write(regs::kCutCols, 100);
  both.Write(regs::kCutRows, 100);
  both.Lane(0, 0, 64, 0, 0);
  both.Write(regs::kCtrl, regs::kCtrlStart);
  EXPECT_EQ(ErrorOf(both.Status()), regs::kErrorBadLane);
  // A lane the component does not have; a cut wider than 65535 cells.
  both.Lane(0, 0, 5, 0, 0);
  both.Write(regs::kLaneMask, 1u << 8);
  both.Write(regs::kCtrl, regs::kCtrlStart);
  EXPECT_EQ(ErrorOf(both.Status()), regs::kErrorBadLane);
  both.Write(regs::kLaneMask, 1);
  both.Write(regs::kCutCols, 70000);
  both.Write(regs::kCtrl, regs::kCtrlStart);
  EXPECT_EQ(ErrorOf(both.Status()), regs::kErrorBadLane);
  // RESET clears the status and the lanes.
  both.Write(regs::kCtrl, regs::kCtrlReset);
  EXPECT_EQ(both.Status(), 0u);
  EXPECT_EQ(both.Read(regs::LaneReg(0, regs::kLaneSide)), 0u);
  // STREAM with no job.
  both.Write(regs::kStream, 7);
  EXPECT_EQ(ErrorOf(both.Status()), regs::kErrorStream);
  // An empty cut is done at once, in 0 cycles.
  both.Write(regs::kCtrl, regs::kCtrlReset);
  both.Write(regs::kCutCols, 0);
  both.Write(regs::kLaneMask, 0);
  both.Write(regs::kCtrl, regs::kCtrlStart);
  EXPECT_EQ(both.Status(), regs::kStatusDone);
  EXPECT_EQ(both.Read(regs::kCyclesLo), 0u);
  // A job of 2 x 2 cells, one lane, a weight written while it runs.
  both.Write(regs::kCutCols, 2);
  both.Write(regs::kCutRows, 2);
  both.Lane(0, 1, 1, 1, 1);
  both.Write(regs::kLaneMask, 1);
  both.Write(regs::kWaddr, 1u << 16);
  both.Write(regs::kWdataLo, 3);
  both.Write(regs::kWdataHi, 0);
  EXPECT_EQ(both.Read(regs::kWaddr), (1u << 16) | 1u);
  both.Write(regs::kCtrl, regs::kCtrlStart);
  EXPECT_EQ(both.Status(), regs::kStatusBusy);
  both.Write(regs::kWdataHi, 0);
  EXPECT_EQ(ErrorOf(both.Status()), regs::kErrorWeightBusy);
  // The same job run through: cells 1..4 (density) and 10..40 (shelter);
  // the lane's 1 x 1 window at (1, 1) takes the last cell: 3 * 4 and 3 * 40.
  both.Write(regs::kCtrl, regs::kCtrlStart);
  for (uint32_t c = 1; c <= 4; ++c) {
    both.Write(regs::kStream, c);
    both.Write(regs::kStream, 10 * c);
  }
  EXPECT_EQ(both.Status(), regs::kStatusDone);
  EXPECT_EQ(both.Read(regs::LaneReg(0, regs::kLaneImpact)), 12u);
  EXPECT_EQ(both.Read(regs::LaneReg(0, regs::kLaneShelter)), 120u);
  EXPECT_EQ(both.Read(regs::LaneReg(1, regs::kLaneImpact)), 0u);
  // One cell too many.
  both.Write(regs::kStream, 5);
  EXPECT_EQ(ErrorOf(both.Status()), regs::kErrorStream);
}

TEST(RtlComponentTest, StreamsOneCellPerClock) {
  // Driven through its registers: a 37 x 23 cut, two lanes. The sink takes
  // one cell per clock, and the job takes exactly the cut's cells plus the
  // 2-clock drain (kPipelineCycles) from START to DONE; DONE shows in the
  // third STATUS read after the last cell (the drain, then the read's latency).
  auto bus = OpenVerilatedComponent("l8-board");
  ASSERT_TRUE(bus.ok());
  SimulatedComponentBus& b = **bus;
  constexpr uint32_t kCols = 37, kRows = 23, kCells = kCols * kRows;
  b.Write32(regs::kCutCols, kCols);
  b.Write32(regs::kCutRows, kRows);
  const uint32_t lanes[2][4] = {{0, 5, 0, 0}, {1, 21, 16, 2}};  // slot, side, col, row
  for (uint32_t l = 0; l < 2; ++l) {
    for (uint32_t r = 0; r < 4; ++r) b.Write32(regs::LaneReg(l, 4 * r), lanes[l][r]);
  }
  b.Write32(regs::kLaneMask, 3);
  b.Write32(regs::kCtrl, regs::kCtrlStart);
  std::vector<uint32_t> words;
  for (uint32_t c = 0; c < kCells; ++c) {
    words.push_back(c);
    words.push_back(c % 11);
  }
  const uint64_t before_stream = b.cycles();
  b.WriteStream(words);
  EXPECT_EQ(b.cycles() - before_stream, kCells) << "one cell per clock";
  int reads = 0;
  uint32_t status = 0;
  while (!((status = b.Read32(regs::kStatus)) & regs::kStatusDone) && reads < 100) ++reads;
  EXPECT_EQ(reads + 1, static_cast<int>(ComponentModel::kPipelineCycles) + 1);
  EXPECT_EQ(status, regs::kStatusDone);
  EXPECT_EQ(b.Read32(regs::kCyclesLo), kCells + ComponentModel::kPipelineCycles);
  EXPECT_EQ(b.Read32(regs::kCyclesHi), 0u);

  // Through MmioDevice: one 21 x 21 kernel along a row, 64 sites one cell
  // apart, so 8 jobs of 8 lanes sharing a 28 x 21 cut. Job cycles: the cut's
  // cells, the drain and the one clock MmioDevice reads STATUS after START.
  // Bus clocks, exactly: the kernel once (WADDR and 441 weights of two
  // words), then per job 8 lanes x 4 registers, CUT_COLS, CUT_ROWS,
  // LANE_MASK, START, the STATUS read, 588 cells, 3 STATUS polls, 8 lanes x 8
  // result words and CYCLES_HI/LO.
  Fixture f = MakeFixture(NumberFormat::Board(), Density::kRandom, {10}, 0, 51);
  for (int s = 0; s < 64; ++s) f.sites.push_back({1, 1, 5 + s, 20});
  auto leg_bus = OpenVerilatedComponent("l8-board");
  ASSERT_TRUE(leg_bus.ok());
  SimulatedComponentBus* raw = leg_bus->get();
  auto device = MmioDevice::Open(*std::move(leg_bus), {});
  ASSERT_TRUE(device.ok());
  const size_t n = f.sites.size();
  std::vector<Accumulator> impact(n), shelter(n);
  uint64_t cycles = 0;
  const uint64_t before = raw->cycles();
  ASSERT_TRUE((*device)->Evaluate(f.map, f.kernels, f.sites, impact, shelter, &cycles).ok());
  constexpr uint64_t kCut = 28 * 21, kJobs = 8;
  EXPECT_EQ((*device)->jobs(), kJobs);
  EXPECT_EQ((*device)->kernel_uploads(), 1u);
  EXPECT_EQ(cycles, kJobs * (kCut + ComponentModel::kPipelineCycles + 1));
  const uint64_t per_job = 8 * 4 + 3 + 1 + 1 + kCut + 3 + 8 * 8 + 2;
  EXPECT_EQ(raw->cycles() - before, (1 + 2 * 21 * 21) + kJobs * per_job);
}

}  // namespace
}  // namespace riskplan::accel
