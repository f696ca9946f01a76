// Helpers of the RTL tests: the verilated component behind MmioDevice, and
// the comparison of its sums with the software model's (ModelDevice) and of
// its job cycles with the register-level ComponentModel's.
#ifndef RISKPLAN_TESTS_RTL_RTL_TEST_UTIL_H_
#define RISKPLAN_TESTS_RTL_RTL_TEST_UTIL_H_

#include <memory>
#include <string>
#include <vector>

#include "accel/blobs.h"
#include "accel/fixed_point.h"
#include "accel/rtl/verilated_component.h"
#include "accel/shim/component_model.h"
#include "accel/shim/device.h"
#include "accel/shim/mmio_device.h"
#include "gtest/gtest.h"

namespace riskplan::accel::testing {

// A quantised map, kernel table and the sites to evaluate on them.
struct Fixture {
  QuantizedMap map;
  QuantizedKernelTable kernels;
  std::vector<DeviceSite> sites;
};

// The verilated configuration `config` behind an MmioDevice using at most
// `max_lanes` of its lanes (0: all); null, with a test failure, if it fails.
inline std::unique_ptr<MmioDevice> OpenRtl(const std::string& config, uint32_t max_lanes = 0) {
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

inline const RtlConfig& ConfigNamed(const std::string& name) {
  for (const RtlConfig& c : VerilatedConfigs()) {
    if (c.name == name) return c;
  }
  ADD_FAILURE() << "no configuration " << name;
  return VerilatedConfigs()[0];
}

// Sums of the RTL, the software model and the ComponentModel (same lanes
// and slots as the RTL) on `f`: all three equal, and the RTL's job cycles
// equal the ComponentModel's.
inline void ExpectSameAsModel(const std::string& config_name, const Fixture& f,
                              uint32_t max_lanes = 0) {
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
  ASSERT_TRUE((*component)->Evaluate(f.map, f.kernels, f.sites, ci, cs, &component_cycles).ok());
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

}  // namespace riskplan::accel::testing

#endif  // RISKPLAN_TESTS_RTL_RTL_TEST_UTIL_H_
