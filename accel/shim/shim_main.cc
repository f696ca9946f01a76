// riskplan-fpga-shim: the daemon that runs on an FPGA board (or beside a
// model of one) and serves the shim protocol (docs/shim-protocol.md) to
// riskplan servers' FPGA workers.
//
//   riskplan-fpga-shim --listen=HOST:PORT --device=model [--format=board]
//   riskplan-fpga-shim --listen=0.0.0.0:7070 --device=mmio --mmio_device=/dev/mem
//                      --mmio_base=0xff200000
//
// Once it listens it prints one line, `riskplan-fpga-shim listening on
// HOST:PORT`, with the real port (port 0 picks one). SIGTERM or SIGINT stop
// it.
#include <signal.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <string>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "absl/flags/usage_config.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "accel/shim/component_model.h"
#include "accel/shim/device.h"
#include "accel/shim/mmio_device.h"
#include "accel/shim/register_bus.h"
#include "accel/shim/shim_server.h"
#ifdef RISKPLAN_HAVE_VERILATOR
#include "accel/rtl/verilated_component.h"
#endif

ABSL_FLAG(std::string, listen, "127.0.0.1:7070", "HOST:PORT to listen on (port 0 picks one)");
ABSL_FLAG(std::string, device, "model",
          "device backend: model (the fixed-point datapath in software), mmio (the component's "
          "registers on a board), verilator (the component's RTL, simulated cycle by cycle)");
ABSL_FLAG(std::string, format, "board",
          "number format of the model backend: board (w32m32a80), precise (w48m48a128) or "
          "wWmMaA; the mmio and verilator backends read the component's");
ABSL_FLAG(std::string, mmio_device, "/dev/mem",
          "mmio: /dev/mem, /dev/uioN, a file, or 'model' for the in-memory component model");
ABSL_FLAG(std::string, mmio_base, "0xff200000",
          "mmio: byte address of the component's CSR slave in --mmio_device (0 for UIO)");
ABSL_FLAG(int, model_lanes, 8, "mmio with --mmio_device=model: lanes of the component model");
ABSL_FLAG(std::string, rtl_config, "l8-board",
          "verilator: the verilated configuration of the RTL (l8-board: 8 lanes, w32m32a80; "
          "l16-precise: 16 lanes, w48m48a128)");
ABSL_FLAG(int, lanes, 0, "mmio, verilator: use at most this many of the component's lanes (0: all)");
ABSL_FLAG(int, store_mb, 1024, "room for blobs (maps and kernel tables, quantised), MiB");
ABSL_FLAG(int, max_sites, 65536, "largest EVAL, in sites");
ABSL_FLAG(int, idle_timeout_s, 600, "close connections idle this long, seconds");

namespace riskplan::accel {
namespace {

MmioOptions MmioOptionsFromFlags(const std::string& backend) {
  MmioOptions options;
  options.backend = backend;
  options.max_lanes = static_cast<uint32_t>(std::max(0, absl::GetFlag(FLAGS_lanes)));
  return options;
}

absl::StatusOr<std::unique_ptr<EwmmDevice>> MakeDevice() {
  const std::string kind = absl::GetFlag(FLAGS_device);
  absl::StatusOr<NumberFormat> format = NumberFormat::Parse(absl::GetFlag(FLAGS_format));
  if (!format.ok()) return format.status();
  if (kind == "model") return std::unique_ptr<EwmmDevice>(new ModelDevice(*format));
  if (kind == "mmio") {
    std::unique_ptr<RegisterBus> bus;
    const std::string path = absl::GetFlag(FLAGS_mmio_device);
    if (path == "model") {
      ComponentConfig config;
      config.format = *format;
      config.lanes = static_cast<uint32_t>(absl::GetFlag(FLAGS_model_lanes));
      bus = std::make_unique<ComponentModel>(config);
    } else {
      uint64_t base = 0;
      if (!absl::SimpleHexAtoi(absl::GetFlag(FLAGS_mmio_base), &base)) {
        return absl::InvalidArgumentError("--mmio_base is not a hexadecimal address");
      }
      absl::StatusOr<std::unique_ptr<MappedRegisterBus>> mapped =
          MappedRegisterBus::Open(path, base, 0x1000);
      if (!mapped.ok()) return mapped.status();
      bus = *std::move(mapped);
    }
    absl::StatusOr<std::unique_ptr<MmioDevice>> device =
        MmioDevice::Open(std::move(bus), MmioOptionsFromFlags("mmio"));
    if (!device.ok()) return device.status();
    return std::unique_ptr<EwmmDevice>(*std::move(device));
  }
  if (kind == "verilator") {
#ifdef RISKPLAN_HAVE_VERILATOR
    absl::StatusOr<std::unique_ptr<SimulatedComponentBus>> bus =
        OpenVerilatedComponent(absl::GetFlag(FLAGS_rtl_config));
    if (!bus.ok()) return bus.status();
    absl::StatusOr<std::unique_ptr<MmioDevice>> device =
        MmioDevice::Open(*std::move(bus), MmioOptionsFromFlags("verilator"));
    if (!device.ok()) return device.status();
    return std::unique_ptr<EwmmDevice>(*std::move(device));
#else
    return absl::UnimplementedError(
        "--device=verilator: this build has no RTL backend (Verilator was not found when it "
        "was configured; install the verilator package and reconfigure)");
#endif
  }
  return absl::InvalidArgumentError("--device must be model, mmio or verilator");
}

int Main() {
  // Block the stop signals before any thread starts, and wait for them here.
  sigset_t stop;
  sigemptyset(&stop);
  sigaddset(&stop, SIGTERM);
  sigaddset(&stop, SIGINT);
  pthread_sigmask(SIG_BLOCK, &stop, nullptr);

  absl::StatusOr<std::unique_ptr<EwmmDevice>> device = MakeDevice();
  if (!device.ok()) {
    std::cerr << "riskplan-fpga-shim: " << device.status().message() << "\n";
    return 2;
  }
  ShimServerOptions options;
  options.limits.store_bytes = uint64_t(absl::GetFlag(FLAGS_store_mb)) << 20;
  options.limits.max_sites_per_eval = static_cast<uint32_t>(absl::GetFlag(FLAGS_max_sites));
  options.idle_timeout = absl::Seconds(absl::GetFlag(FLAGS_idle_timeout_s));
  const DeviceInfo info = (*device)->info();
  ShimServer server(*std::move(device), options);
  absl::StatusOr<std::string> bound = server.Start(absl::GetFlag(FLAGS_listen));
  if (!bound.ok()) {
    std::cerr << "riskplan-fpga-shim: " << bound.status().message() << "\n";
    return 1;
  }
  std::cerr << "riskplan-fpga-shim: device " << info.backend << " (" << info.device << ", "
            << info.firmware << "), format " << info.format.Name() << ", " << info.lanes
            << " lane(s)\n";
  std::cout << "riskplan-fpga-shim listening on " << *bound << std::endl;
  int signal = 0;
  sigwait(&stop, &signal);
  server.Stop();
  // What the device did, and what it would take at its clock.
  const ShimContext& served = server.context();
  const uint64_t sites = served.sites.load(), cycles = served.device_cycles.load();
  std::cerr << "riskplan-fpga-shim: served " << served.evals.load() << " EVAL(s), " << sites
            << " site(s)";
  if (cycles > 0 && info.clock_hz > 0) {
    std::cerr << "; device " << cycles << " cycles = "
              << 1e3 * static_cast<double>(cycles) / static_cast<double>(info.clock_hz)
              << " ms at " << static_cast<double>(info.clock_hz) / 1e6 << " MHz ("
              << static_cast<double>(cycles) / static_cast<double>(sites) << " cycles per site)";
  }
  std::cerr << "\n";
  return 0;
}

}  // namespace
}  // namespace riskplan::accel

int main(int argc, char** argv) {
  absl::SetProgramUsageMessage(
      "the riskplan FPGA shim: serves the shim protocol for one board.\n"
      "  riskplan-fpga-shim --listen=HOST:PORT --device=<model|mmio|verilator> ...");
  // --help lists this file's flags (Abseil's default looks for a file named
  // after the program).
  absl::FlagsUsageConfig config;
  config.contains_help_flags = [](absl::string_view file) {
    return absl::StrContains(file, "shim/shim_main.cc");
  };
  config.contains_helpshort_flags = config.contains_help_flags;
  absl::SetFlagsUsageConfig(config);
  absl::ParseCommandLine(argc, argv);
  return riskplan::accel::Main();
}
