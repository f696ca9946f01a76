// The RTL of the streaming EWMM component under Verilator (issue 6):
// simulated clock cycles per configuration risk by lane count, for the two
// access patterns of the accelerator benchmarks (samples 5 m apart along
// trajectories, and random configurations over demo-city, both 100 m above
// ground), and what they imply at the component's clock (100 MHz on a
// Cyclone V).
//
// Cycles are counted by the simulation, so they do not depend on the
// machine's load. Two counts per row:
//   job   the component's CYCLES register, START to DONE of each job: the
//         stream (one cut cell per clock) and the 2-clock drain, plus the
//         one clock MmioDevice spends reading STATUS after START;
//   bus   every simulated clock, with one clock per CSR access: kernel
//         loads, lane set-up, result reads, status polls. On a board the
//         lightweight HPS-to-FPGA bridge takes tens of clocks per access,
//         so this is a lower bound of the processor's side.
//
//   riskplan-bench-rtl [--configs=4096] [--lanes=1,2,4,8,16] [--config=l16-precise]
//                      [--report_clock_hz=50e6]
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_split.h"
#include "accel/blobs.h"
#include "accel/rtl/verilated_component.h"
#include "accel/shim/mmio_device.h"
#include "bench/demo_city_configs.h"
#include "cmdline/help.h"
#include "core/map/demo_city.h"
#include "core/risk/risk_model.h"

ABSL_FLAG(int, configs, 4096, "configurations per pattern");
ABSL_FLAG(std::string, lanes, "1,2,4,8,16", "lane counts to measure (at most the config's)");
ABSL_FLAG(std::string, config, "l16-precise", "verilated configuration (its lanes bound --lanes)");
ABSL_FLAG(double, report_clock_hz, 0,
          "clock (Hz) of the risks/s columns; 0: the configuration's CLOCK_HZ (100 MHz)");

namespace riskplan::accel {
namespace {

int Main() {
  auto map = MakeDemoCity();
  if (!map.ok()) {
    std::fprintf(stderr, "demo-city: %s\n", std::string(map.status().message()).c_str());
    return 1;
  }
  auto model = RiskModel::Create(*map, ModelParams{});
  if (!model.ok()) return 1;
  const RiskModel& m = **model;

  const std::string config_name = absl::GetFlag(FLAGS_config);
  RtlConfig config;
  for (const RtlConfig& c : VerilatedConfigs()) {
    if (c.name == config_name) config = c;
  }
  if (config.lanes == 0) {
    std::fprintf(stderr, "no verilated configuration %s\n", config_name.c_str());
    return 2;
  }
  auto quantized_map = QuantizeMapBlob(EncodeMapBlob(m.map()), config.format, 64);
  auto kernels = QuantizeKernelsBlob(EncodeKernelsBlob(KernelSetOf(m.table())), config.format,
                                     static_cast<int>(config.max_side));
  if (!quantized_map.ok() || !kernels.ok()) {
    std::fprintf(stderr, "cannot quantise demo-city for %s\n", config.format.Name().c_str());
    return 1;
  }
  kernels->id = 1;

  std::vector<uint32_t> lane_counts;
  for (absl::string_view part : absl::StrSplit(absl::GetFlag(FLAGS_lanes), ',')) {
    uint32_t l = 0;
    if (absl::SimpleAtoi(part, &l) && l >= 1 && l <= config.lanes) lane_counts.push_back(l);
  }
  const size_t n = static_cast<size_t>(absl::GetFlag(FLAGS_configs));
  const double clock = absl::GetFlag(FLAGS_report_clock_hz) > 0
                           ? absl::GetFlag(FLAGS_report_clock_hz)
                           : static_cast<double>(config.clock_hz);
  std::printf("RTL %s (%s), demo-city at 100 m above ground, %zu configurations per pattern\n\n",
              config.name.c_str(), config.format.Name().c_str(), n);
  std::printf(
      "| pattern | lanes | risks/job | job cycles/risk | bus cycles/risk | risks/s at %g MHz "
      "(job) | (bus) | kernel loads | simulated clocks/s |\n",
      clock / 1e6);
  std::printf("|---|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  for (const bool along : {true, false}) {
    const std::vector<Pose> poses =
        along ? bench::AlongTrajectories(m, n) : bench::RandomConfigurations(m, n);
    std::vector<DeviceSite> sites;
    for (const Pose& q : poses) {
      KernelSite s;
      if (!m.Locate(q, &s)) continue;
      sites.push_back(DeviceSite{static_cast<uint16_t>(s.height_bin),
                                 static_cast<uint16_t>(s.heading_bin), s.impact_i, s.impact_j});
    }
    for (const uint32_t lanes : lane_counts) {
      auto bus = OpenVerilatedComponent(config.name);
      if (!bus.ok()) return 1;
      SimulatedComponentBus* raw = bus->get();
      MmioOptions options;
      options.backend = "verilator";
      options.max_lanes = lanes;
      auto device = MmioDevice::Open(*std::move(bus), options);
      if (!device.ok()) return 1;
      const uint64_t bus_before = raw->cycles();
      std::vector<Accumulator> impact(sites.size()), shelter(sites.size());
      uint64_t job_cycles = 0;
      const auto t0 = std::chrono::steady_clock::now();
      if (!(*device)
               ->Evaluate(*quantized_map, *kernels, sites, impact, shelter, &job_cycles)
               .ok()) {
        std::fprintf(stderr, "evaluation failed\n");
        return 1;
      }
      const double seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const uint64_t bus_cycles = raw->cycles() - bus_before;
      const double k = static_cast<double>(sites.size());
      std::printf("| %s | %u | %.2f | %.1f | %.1f | %.2f M | %.2f M | %llu | %.2f M |\n",
                  along ? "along trajectories" : "random", lanes,
                  k / static_cast<double>((*device)->jobs()), job_cycles / k, bus_cycles / k,
                  clock / (job_cycles / k) / 1e6, clock / (bus_cycles / k) / 1e6,
                  static_cast<unsigned long long>((*device)->kernel_uploads()),
                  bus_cycles / seconds / 1e6);
    }
  }
  return 0;
}

}  // namespace
}  // namespace riskplan::accel

int main(int argc, char** argv) {
  riskplan::cmdline::ParseCommandLine(
      argc, argv,
      {.program = "riskplan-bench-rtl",
       .usage = "cycles per configuration risk of the verilated RTL by lane count "
                "(docs/rtl.md)."});
  return riskplan::accel::Main();
}
