// The RTL of the streaming EWMM component (accel/rtl/rp_ewmm.sv) under
// Verilator, driven through its registers and stream sink by the shim's
// MmioDevice, against the software model of the datapath (ModelDevice): the
// same sums bit for bit on thousands of random sites and kernels, with the
// edge cases (windows across and beyond the map border, an empty density
// layer, the largest kernel, weights that saturate), the same cycle counts
// as the register-level ComponentModel, and the same answers to bad jobs.
#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "accel/blobs.h"
#include "accel/fixed_point.h"
#include "accel/rtl/verilated_component.h"
#include "accel/shim/component_model.h"
#include "accel/shim/component_regs.h"
#include "accel/shim/device.h"
#include "accel/shim/mmio_device.h"
#include "core/random.h"
#include "gtest/gtest.h"

namespace riskplan::accel {
namespace {

enum class Density { kRandom, kEmpty, kFull };

struct Fixture {
  QuantizedMap map;
  QuantizedKernelTable kernels;
  std::vector<DeviceSite> sites;
};

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
    return std::pair<uint16_t, uint16_t>(
        1 + static_cast<uint16_t>(rng.Uniform() * set.height_bins),
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

std::unique_ptr<MmioDevice> OpenRtl(const std::string& config, uint32_t max_lanes = 0) {
  auto bus = OpenVerilatedComponent(config);
  EXPECT_TRUE(bus.ok()) << bus.status();
  if (!bus.ok()) return nullptr;
  MmioOptions options;
  options.backend = "verilator";
  options.max_lanes = max_lanes;
  auto device = MmioDevice::Open(*std::move(bus), options);
  EXPECT_TRUE(device.ok()) << device.status();
  return device.ok() ? *std::move(device) : nullptr;
}

const RtlConfig& ConfigNamed(const std::string& name) {
  for (const RtlConfig& c : VerilatedConfigs()) {
    if (c.name == name) return c;
  }
  ADD_FAILURE() << "no configuration " << name;
  return VerilatedConfigs()[0];
}

// Sums of the RTL, the software model and the ComponentModel (same lanes
// and slots as the RTL) on `f`: all three equal, and the RTL's job cycles
// equal the ComponentModel's.
void ExpectSameAsModel(const std::string& config_name, const Fixture& f, uint32_t max_lanes = 0) {
  const RtlConfig& config = ConfigNamed(config_name);
  std::unique_ptr<MmioDevice> rtl = OpenRtl(config_name, max_lanes);
  ASSERT_NE(rtl, nullptr);
  const size_t n = f.sites.size();
  std::vector<Accumulator> impact(n), shelter(n);
  uint64_t cycles = 0;
  ASSERT_TRUE(rtl->Evaluate(f.map, f.kernels, f.sites, impact, shelter, &cycles).ok());

  ModelDevice model(config.format);
  std::vector<Accumulator> want_i(n), want_s(n);
  uint64_t unused = 0;
  ASSERT_TRUE(model.Evaluate(f.map, f.kernels, f.sites, want_i, want_s, &unused).ok());
  size_t mismatches = 0;
  for (size_t s = 0; s < n; ++s) {
    if (impact[s] != want_i[s] || shelter[s] != want_s[s]) {
      if (++mismatches <= 5) {
        ADD_FAILURE() << config_name << ": site " << s << " (b " << f.sites[s].height_bin << ", k "
                      << f.sites[s].heading_bin << ", cell " << f.sites[s].impact_i << ", "
                      << f.sites[s].impact_j << ") differs from the model";
      }
    }
  }
  EXPECT_EQ(mismatches, 0u) << config_name << ": of " << n << " sites";

  ComponentConfig cc;
  cc.format = config.format;
  cc.lanes = config.lanes;
  cc.weight_slots = config.weight_slots;
  cc.max_side = config.max_side;
  MmioOptions options;
  options.max_lanes = max_lanes;
  auto component = MmioDevice::Open(std::make_unique<ComponentModel>(cc), options);
  ASSERT_TRUE(component.ok());
  std::vector<Accumulator> ci(n), cs(n);
  uint64_t component_cycles = 0;
  ASSERT_TRUE(
      (*component)->Evaluate(f.map, f.kernels, f.sites, ci, cs, &component_cycles).ok());
  EXPECT_EQ(ci, impact);
  EXPECT_EQ(cs, shelter);
  // The component counts from START to DONE. MmioDevice reads STATUS once
  // between START and the first cell (to see a refused job before streaming
  // it), a clock in which the component waits for the stream; otherwise the
  // RTL takes a cell every clock and drains in kPipelineCycles, as modelled.
  EXPECT_EQ(rtl->jobs(), (*component)->jobs());
  EXPECT_EQ(cycles, component_cycles + rtl->jobs())
      << config_name << ": RTL and ComponentModel job cycles";
  EXPECT_GT(cycles, 0u);
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
  // A 21 x 21 kernel along a leg: 8 lanes share cuts; the component's cycles
  // are the cut's cells plus the 2-cycle drain, and the bus's clocks (with
  // kernel loads, lane set-up and result reads) are counted separately.
  const Fixture f = MakeFixture(NumberFormat::Board(), Density::kRandom, {10}, 64, 51);
  auto bus = OpenVerilatedComponent("l8-board");
  ASSERT_TRUE(bus.ok());
  SimulatedComponentBus* raw = bus->get();
  const uint64_t before = raw->cycles();
  auto device = MmioDevice::Open(*std::move(bus), {});
  ASSERT_TRUE(device.ok());
  const size_t n = f.sites.size();
  std::vector<Accumulator> i(n), s(n);
  uint64_t cycles = 0;
  ASSERT_TRUE((*device)->Evaluate(f.map, f.kernels, f.sites, i, s, &cycles).ok());
  EXPECT_GT(raw->cycles() - before, cycles);
  EXPECT_GE(cycles, (*device)->jobs() * (21 * 21 + ComponentModel::kPipelineCycles));
}

}  // namespace
}  // namespace riskplan::accel
