// The mmio backend against the in-memory component model: bit for bit the
// software model's sums, for several lane counts and formats, with kernels
// kept in their slots; and the register mapping on a plain file.
#include "accel/shim/mmio_device.h"

#include <fcntl.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>

#include "accel/shim/component_model.h"
#include "accel/shim/component_regs.h"
#include "core/base/random.h"
#include "gtest/gtest.h"

namespace riskplan::accel {
namespace {

struct Fixture {
  QuantizedMap map;
  QuantizedKernelTable kernels;
  std::vector<DeviceSite> sites;
};

Fixture MakeFixture(const NumberFormat& format, uint64_t seed) {
  Rng rng(seed);
  const int nx = 70, ny = 50;
  std::vector<float> density(nx * ny), shelter(nx * ny);
  for (int c = 0; c < nx * ny; ++c) {
    density[c] = static_cast<float>(0.05 * rng.Uniform());
    shelter[c] = static_cast<float>(10.0 * rng.Uniform());
  }
  Fixture f;
  f.map = QuantizeMap(nx, ny, density.data(), shelter.data(), format, 16);
  KernelSet set;
  set.height_bins = 4;
  set.heading_bins = 6;
  set.half_width = {1, 4, 7, 12};
  for (int b = 1; b <= 4; ++b) {
    const int side = 2 * set.half_width[b - 1] + 1;
    for (int k = 0; k < 6; ++k) {
      std::vector<double> w(side * side);
      double sum = 0;
      for (double& x : w) sum += (x = rng.Uniform());
      for (double& x : w) x /= sum;
      set.weights.push_back(w);
    }
  }
  f.kernels = *QuantizeKernelsBlob(EncodeKernelsBlob(set), format, 63);
  f.kernels.id = 1;
  // Legs of neighbouring sites (shared kernels, overlapping windows) and
  // scattered ones, some across and beyond the map's edges.
  for (int leg = 0; leg < 30; ++leg) {
    const uint16_t b = 1 + static_cast<uint16_t>(rng.Uniform() * 4);
    const uint16_t k = static_cast<uint16_t>(rng.Uniform() * 6);
    int i = -10 + static_cast<int>(rng.Uniform() * (nx + 20));
    int j = -10 + static_cast<int>(rng.Uniform() * (ny + 20));
    const int di = rng.Uniform() < 0.5 ? 1 : 0, dj = 1 - di;
    for (int s = 0; s < 12; ++s) f.sites.push_back({b, k, i += di, j += dj});
    f.sites.push_back({static_cast<uint16_t>(1 + rng.Uniform() * 4),
                       static_cast<uint16_t>(rng.Uniform() * 6),
                       static_cast<int>(rng.Uniform() * nx), static_cast<int>(rng.Uniform() * ny)});
  }
  return f;
}

void ExpectSameAsModel(const NumberFormat& format, uint32_t lanes, uint32_t slots) {
  const Fixture f = MakeFixture(format, lanes * 31 + slots);
  ComponentConfig config;
  config.format = format;
  config.lanes = lanes;
  config.weight_slots = slots;
  auto device = MmioDevice::Open(std::make_unique<ComponentModel>(config), {});
  ASSERT_TRUE(device.ok()) << device.status();
  EXPECT_EQ((*device)->info().lanes, lanes);
  EXPECT_EQ((*device)->info().format, format);
  std::vector<Accumulator> impact(f.sites.size()), shelter(f.sites.size());
  uint64_t cycles = 0;
  ASSERT_TRUE((*device)->Evaluate(f.map, f.kernels, f.sites, impact, shelter, &cycles).ok());
  ModelDevice model(format);
  std::vector<Accumulator> want_i(f.sites.size()), want_s(f.sites.size());
  uint64_t unused = 0;
  ASSERT_TRUE(model.Evaluate(f.map, f.kernels, f.sites, want_i, want_s, &unused).ok());
  for (size_t n = 0; n < f.sites.size(); ++n) {
    EXPECT_TRUE(impact[n] == want_i[n] && shelter[n] == want_s[n])
        << "site " << n << " lanes " << lanes << " " << format.Name();
  }
  EXPECT_GT(cycles, 0u);
  // Lanes share cuts: fewer jobs than sites, and kernels mostly stay loaded.
  if (lanes > 1) {
    EXPECT_LT((*device)->jobs(), f.sites.size());
  }
  EXPECT_LT((*device)->kernel_uploads(), f.sites.size());
}

TEST(MmioDeviceTest, OneLaneMatchesTheModel) { ExpectSameAsModel(NumberFormat::Board(), 1, 2); }
TEST(MmioDeviceTest, FourLanesMatchTheModel) { ExpectSameAsModel(NumberFormat::Board(), 4, 4); }
TEST(MmioDeviceTest, EightLanesMatchTheModel) { ExpectSameAsModel(NumberFormat::Board(), 8, 8); }
TEST(MmioDeviceTest, WideCellsTakeTwoStreamWords) {
  ExpectSameAsModel(NumberFormat::Precise(), 8, 3);
}

TEST(MmioDeviceTest, RefusesABusWithoutTheComponent) {
  class Empty final : public RegisterBus {
   public:
    uint32_t Read32(uint32_t) override { return 0; }
    void Write32(uint32_t, uint32_t) override {}
    std::string Name() const override { return "empty"; }
  };
  auto device = MmioDevice::Open(std::make_unique<Empty>(), {});
  EXPECT_EQ(device.status().code(), absl::StatusCode::kFailedPrecondition);
}

TEST(MmioDeviceTest, AComponentThatNeverFinishesTimesOut) {
  // A bus that shows the component but never reports DONE.
  class Stuck final : public RegisterBus {
   public:
    uint32_t Read32(uint32_t offset) override {
      if (offset == regs::kStatus) return regs::kStatusBusy;
      return model_.Read32(offset);
    }
    void Write32(uint32_t offset, uint32_t value) override { model_.Write32(offset, value); }
    std::string Name() const override { return "stuck"; }

   private:
    ComponentModel model_{ComponentConfig{}};
  };
  MmioOptions options;
  options.job_timeout = absl::Milliseconds(50);
  auto device = MmioDevice::Open(std::make_unique<Stuck>(), options);
  ASSERT_TRUE(device.ok());
  const Fixture f = MakeFixture(NumberFormat::Board(), 5);
  std::vector<Accumulator> i(1), s(1);
  uint64_t cycles = 0;
  EXPECT_EQ(
      (*device)->Evaluate(f.map, f.kernels, std::span(f.sites).first(1), i, s, &cycles).code(),
      absl::StatusCode::kDeadlineExceeded);
}

TEST(ComponentModelTest, RefusesALaneOutsideTheCut) {
  ComponentModel c(ComponentConfig{});
  c.Write32(regs::kCutCols, 5);
  c.Write32(regs::kCutRows, 5);
  c.Write32(regs::kLaneMask, 1);
  c.Write32(regs::LaneReg(0, regs::kLaneSide), 3);
  c.Write32(regs::LaneReg(0, regs::kLaneCol), 3);  // 3 + 3 > 5
  c.Write32(regs::kCtrl, regs::kCtrlStart);
  const uint32_t status = c.Read32(regs::kStatus);
  EXPECT_TRUE(status & regs::kStatusError);
  EXPECT_EQ((status >> 8) & 0xff, regs::kErrorBadLane);
}

TEST(MappedRegisterBusTest, MapsAFileAtAnOffset) {
  char path[] = "/tmp/riskplan-mmio-XXXXXX";
  const int fd = mkstemp(path);
  ASSERT_GE(fd, 0);
  // 8 KiB of zeros, and the ID word at byte 0x1000 + regs::kId.
  std::vector<char> zeros(8192, 0);
  ASSERT_EQ(write(fd, zeros.data(), zeros.size()), 8192);
  const uint32_t id = regs::kIdValue;
  ASSERT_EQ(pwrite(fd, &id, 4, 0x1000), 4);
  close(fd);
  {
    auto bus = MappedRegisterBus::Open(path, 0x1000, regs::kSpanBytes);
    ASSERT_TRUE(bus.ok()) << bus.status();
    EXPECT_EQ((*bus)->Read32(regs::kId), regs::kIdValue);
    (*bus)->Write32(regs::kCutCols, 0x12345678);
    EXPECT_EQ((*bus)->Read32(regs::kCutCols), 0x12345678u);
    EXPECT_EQ((*bus)->Read32(0x100000), 0xffffffffu);  // outside the span
  }
  // The write went through to the file.
  const int again = open(path, O_RDONLY);
  uint32_t word = 0;
  ASSERT_EQ(pread(again, &word, 4, 0x1000 + regs::kCutCols), 4);
  EXPECT_EQ(word, 0x12345678u);
  close(again);
  unlink(path);
  EXPECT_FALSE(MappedRegisterBus::Open("/nonexistent/mem", 0, 4096).ok());
}

}  // namespace
}  // namespace riskplan::accel
