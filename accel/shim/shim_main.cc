// riskplan-fpga-shim: the daemon that runs on an FPGA board (or beside a
// model of one) and serves the shim protocol (docs/shim-protocol.md) to
// riskplan servers' FPGA workers.
//
//   riskplan-fpga-shim --listen=HOST:PORT --device=model [--format=board]
//   riskplan-fpga-shim --listen=0.0.0.0:7070 --device=mmio --mmio_device=/dev/mem
//                      --mmio_base=0xff200000
//   riskplan-fpga-shim --device=verilator [--rtl_config=l8-board] [--report_clock_hz=50e6]
//
// Once it listens it prints one line, `riskplan-fpga-shim listening on
// HOST:PORT`, with the real port (port 0 picks one). SIGTERM or SIGINT stop
// it; it then reports on stderr what the device did: the EVALs and sites
// served, the component's job cycles (START to DONE, as in every EVAL reply)
// and, for the verilator backend, every simulated clock of the bus (the jobs
// and all CSR traffic: kernel loads, lane set-up, status polls, result
// reads), each as a time at the reported clock (docs/rtl.md, "Cycles").
#include <signal.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>

#include "absl/flags/flag.h"
#include "absl/strings/numbers.h"
#include "accel/shim/component_model.h"
#include "accel/shim/component_regs.h"
#include "accel/shim/device.h"
#include "accel/shim/mmio_device.h"
#include "accel/shim/register_bus.h"
#include "accel/shim/shim_server.h"
#include "cmdline/help.h"
#include "net/net.h"
#include "net/tls_context.h"
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
ABSL_FLAG(int, lanes, 0,
          "mmio, verilator: use at most this many of the component's lanes (0: all)");
ABSL_FLAG(double, report_clock_hz, 0,
          "mmio, verilator: the clock, in Hz, at which the shim reports the board's time (in "
          "HELLO's clock_hz, and in the report when it stops), e.g. 50e6; 0: the component's "
          "CLOCK_HZ register (100 MHz in the verilated builds). The model backend counts no "
          "cycles and ignores it");
ABSL_FLAG(int, store_mb, 1024, "room for blobs (maps and kernel tables, quantised), MiB");
ABSL_FLAG(int, max_sites, 65536, "largest EVAL, in sites");
ABSL_FLAG(int, idle_timeout_s, 600, "close connections idle this long, seconds");
ABSL_FLAG(std::string, tls_cert, "",
          "TLS: this shim's certificate chain (PEM); with --tls_key and --tls_client_ca every "
          "connection is mutual TLS. Re-read when it changes (rotate by swapping its directory)");
ABSL_FLAG(std::string, tls_key, "", "TLS: the private key of --tls_cert (PEM, unencrypted)");
ABSL_FLAG(std::string, tls_client_ca, "",
          "TLS: CA bundle that must have signed the server's certificate (required with TLS: "
          "the shim refuses a server it cannot authenticate)");
ABSL_FLAG(std::string, tls_crl, "",
          "TLS: revocation list (PEM) checked on the server's certificate");
ABSL_FLAG(bool, allow_plaintext, false,
          "listen in plaintext on an address that is not loopback (without TLS flags the shim "
          "refuses to)");

namespace riskplan::accel {
namespace {

// A device whose DeviceInfo reports `clock_hz` (--report_clock_hz) in place
// of the component's CLOCK_HZ; the cycles are the component's.
class ReportedClockDevice final : public EwmmDevice {
 public:
  ReportedClockDevice(std::unique_ptr<EwmmDevice> device, uint64_t clock_hz)
      : device_(std::move(device)), info_(device_->info()) {
    info_.clock_hz = clock_hz;
  }
  const DeviceInfo& info() const override { return info_; }
  absl::Status Evaluate(const QuantizedMap& map, const QuantizedKernelTable& kernels,
                        std::span<const DeviceSite> sites, std::span<Accumulator> impact,
                        std::span<Accumulator> shelter, uint64_t* cycles) override {
    return device_->Evaluate(map, kernels, sites, impact, shelter, cycles);
  }

 private:
  const std::unique_ptr<EwmmDevice> device_;
  DeviceInfo info_;
};

// The device, and (verilator) the count of every clock its bus simulated.
struct OpenedDevice {
  std::unique_ptr<EwmmDevice> device;
  std::function<uint64_t()> bus_clocks;  // null: the backend cannot count them
};

MmioOptions MmioOptionsFromFlags(const std::string& backend) {
  MmioOptions options;
  options.backend = backend;
  options.max_lanes = static_cast<uint32_t>(std::max(0, absl::GetFlag(FLAGS_lanes)));
  return options;
}

absl::StatusOr<OpenedDevice> MakeDevice() {
  const std::string kind = absl::GetFlag(FLAGS_device);
  absl::StatusOr<NumberFormat> format = NumberFormat::Parse(absl::GetFlag(FLAGS_format));
  if (!format.ok()) return format.status();
  if (kind == "model") return OpenedDevice{std::make_unique<ModelDevice>(*format), nullptr};
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
          MappedRegisterBus::Open(path, base, regs::kSpanBytes);
      if (!mapped.ok()) return mapped.status();
      bus = *std::move(mapped);
    }
    absl::StatusOr<std::unique_ptr<MmioDevice>> device =
        MmioDevice::Open(std::move(bus), MmioOptionsFromFlags("mmio"));
    if (!device.ok()) return device.status();
    return OpenedDevice{*std::move(device), nullptr};
  }
  if (kind == "verilator") {
#ifdef RISKPLAN_HAVE_VERILATOR
    absl::StatusOr<std::unique_ptr<SimulatedComponentBus>> bus =
        OpenVerilatedComponent(absl::GetFlag(FLAGS_rtl_config));
    if (!bus.ok()) return bus.status();
    // Owned by the device from here on; read only while no EVAL runs.
    const SimulatedComponentBus* simulated = bus->get();
    absl::StatusOr<std::unique_ptr<MmioDevice>> device =
        MmioDevice::Open(*std::move(bus), MmioOptionsFromFlags("verilator"));
    if (!device.ok()) return device.status();
    return OpenedDevice{*std::move(device), [simulated] { return simulated->cycles(); }};
#else
    return absl::UnimplementedError(
        "--device=verilator: this build has no RTL backend (Verilator was not found when it "
        "was configured; install the verilator package and reconfigure)");
#endif
  }
  return absl::InvalidArgumentError("--device must be model, mmio or verilator");
}

// The listener's TLS from the flags (null: plaintext, only on loopback
// unless --allow_plaintext).
absl::StatusOr<std::shared_ptr<net::TlsContext>> ListenerTls() {
  net::TlsFiles files{.cert = absl::GetFlag(FLAGS_tls_cert),
                      .key = absl::GetFlag(FLAGS_tls_key),
                      .ca = absl::GetFlag(FLAGS_tls_client_ca),
                      .crl = absl::GetFlag(FLAGS_tls_crl),
                      .flag_prefix = ""};
  if (!files.enabled()) {
    std::string host;
    int port = 0;
    if (absl::Status s = net::SplitHostPort(absl::GetFlag(FLAGS_listen), &host, &port); !s.ok()) {
      return s;
    }
    if (!files.crl.empty()) return absl::InvalidArgumentError("--tls_crl needs TLS");
    if (!net::IsLoopbackHost(host) && !absl::GetFlag(FLAGS_allow_plaintext)) {
      return absl::InvalidArgumentError(
          "--listen is not a loopback address and no --tls_cert/--tls_key/--tls_client_ca were "
          "given: plaintext there needs --allow_plaintext (docs/security.md)");
    }
    return std::shared_ptr<net::TlsContext>();
  }
  if (files.ca.empty()) {
    return absl::InvalidArgumentError(
        "--tls_client_ca is required with TLS: the shim must authenticate the server");
  }
  return net::TlsContext::ForListener(files);
}

// Blocks the stop signals in the calling thread, before any thread starts
// (threads inherit the mask, so none of them takes the signal); Main waits
// for them.
sigset_t BlockStopSignals() {
  sigset_t stop;
  sigemptyset(&stop);
  sigaddset(&stop, SIGTERM);
  sigaddset(&stop, SIGINT);
  pthread_sigmask(SIG_BLOCK, &stop, nullptr);
  return stop;
}

// --report_clock_hz, rounded to whole Hz (0: the component's CLOCK_HZ).
absl::StatusOr<uint64_t> ReportClockFromFlag() {
  const double report_clock_hz = absl::GetFlag(FLAGS_report_clock_hz);
  if (!std::isfinite(report_clock_hz) || report_clock_hz < 0 || report_clock_hz > 1e12) {
    return absl::InvalidArgumentError(
        "--report_clock_hz must be a clock in Hz (0: the component's CLOCK_HZ)");
  }
  return static_cast<uint64_t>(std::llround(report_clock_hz));
}

// The device as served: reporting `clock_hz` where one was asked for. The
// model backend counts no cycles, so it is left as it is, with a warning.
std::unique_ptr<EwmmDevice> WithReportedClock(std::unique_ptr<EwmmDevice> device,
                                              uint64_t clock_hz) {
  if (clock_hz == 0) return device;
  if (device->info().backend == "model") {
    std::cerr << "riskplan-fpga-shim: --report_clock_hz: the model backend counts no cycles; "
                 "ignored\n";
    return device;
  }
  return std::make_unique<ReportedClockDevice>(std::move(device), clock_hz);
}

absl::StatusOr<ShimServerOptions> ServerOptionsFromFlags() {
  ShimServerOptions options;
  absl::StatusOr<std::shared_ptr<net::TlsContext>> tls = ListenerTls();
  if (!tls.ok()) return tls.status();
  options.tls = *std::move(tls);
  options.on_tls_event = [](const std::string& line) {
    std::cerr << "riskplan-fpga-shim: " + line + "\n" << std::flush;
  };
  options.limits.store_bytes = uint64_t(absl::GetFlag(FLAGS_store_mb)) << 20;
  options.limits.max_sites_per_eval = static_cast<uint32_t>(absl::GetFlag(FLAGS_max_sites));
  options.idle_timeout = absl::Seconds(absl::GetFlag(FLAGS_idle_timeout_s));
  return options;
}

void PrintDevice(const DeviceInfo& info) {
  std::cerr << "riskplan-fpga-shim: device " << info.backend << " (" << info.device << ", "
            << info.firmware << "), format " << info.format.Name() << ", " << info.lanes
            << " lane(s)";
  if (info.clock_hz > 0) {
    std::cerr << ", times reported at " << static_cast<double>(info.clock_hz) / 1e6 << " MHz";
  }
  std::cerr << "\n";
}

// What the device did, and what it would take at the reported clock. `bus`
// is the clocks the bus simulated while serving (absent: not counted).
void PrintServed(const ShimContext& served, const DeviceInfo& info,
                 std::optional<uint64_t> bus) {
  const uint64_t sites = served.sites.load(), cycles = served.device_cycles.load();
  const auto report = [&](const char* what, uint64_t count) {
    std::cerr << "; " << what << " " << count << " cycles = "
              << 1e3 * static_cast<double>(count) / static_cast<double>(info.clock_hz) << " ms at "
              << static_cast<double>(info.clock_hz) / 1e6 << " MHz ("
              << static_cast<double>(count) / static_cast<double>(std::max<uint64_t>(sites, 1))
              << " per site)";
  };
  std::cerr << "riskplan-fpga-shim: served " << served.evals.load() << " EVAL(s), " << sites
            << " site(s)";
  if (cycles > 0 && info.clock_hz > 0) {
    report("jobs (START to DONE)", cycles);
    if (bus.has_value()) report("bus (every simulated clock, CSR accesses included)", *bus);
  }
  std::cerr << "\n";
}

int Main() {
  sigset_t stop = BlockStopSignals();
  absl::StatusOr<uint64_t> report_clock_hz = ReportClockFromFlag();
  if (!report_clock_hz.ok()) {
    std::cerr << "riskplan-fpga-shim: " << report_clock_hz.status().message() << "\n";
    return 2;
  }
  absl::StatusOr<OpenedDevice> opened = MakeDevice();
  if (!opened.ok()) {
    std::cerr << "riskplan-fpga-shim: " << opened.status().message() << "\n";
    return 2;
  }
  std::unique_ptr<EwmmDevice> device =
      WithReportedClock(std::move(opened->device), *report_clock_hz);
  absl::StatusOr<ShimServerOptions> options = ServerOptionsFromFlags();
  if (!options.ok()) {
    std::cerr << "riskplan-fpga-shim: cannot start: " << options.status().message() << "\n";
    return 1;
  }
  const DeviceInfo info = device->info();
  const std::function<uint64_t()> bus_clocks = opened->bus_clocks;
  // The clocks of the reset and of reading the component's identity are not
  // the EVALs'.
  const uint64_t bus_clocks_before = bus_clocks ? bus_clocks() : 0;
  ShimServer server(std::move(device), *options);
  absl::StatusOr<std::string> bound = server.Start(absl::GetFlag(FLAGS_listen));
  if (!bound.ok()) {
    std::cerr << "riskplan-fpga-shim: " << bound.status().message() << "\n";
    return 1;
  }
  PrintDevice(info);
  // Flushed at once: whoever started the shim learns the port from this line.
  std::cout << "riskplan-fpga-shim listening on " << *bound << std::endl;
  int signal = 0;
  sigwait(&stop, &signal);
  server.Stop();
  std::optional<uint64_t> bus;
  if (bus_clocks) bus = bus_clocks() - bus_clocks_before;
  PrintServed(server.context(), info, bus);
  return 0;
}

}  // namespace
}  // namespace riskplan::accel

int main(int argc, char** argv) {
  riskplan::cmdline::ProgramHelp help;
  help.program = "riskplan-fpga-shim";
  help.usage =
      "the daemon of an FPGA board (or of a model of one).\n"
      "\n"
      "Serves the shim protocol (docs/shim-protocol.md) to riskplan servers' FPGA workers.\n"
      "\n"
      "  riskplan-fpga-shim --listen=HOST:PORT --device=model [--format=board]\n"
      "  riskplan-fpga-shim --device=mmio --mmio_device=/dev/mem --mmio_base=0xff200000\n"
      "  riskplan-fpga-shim --device=verilator [--rtl_config=l8-board] [--report_clock_hz=50e6]";
  help.footer =
      "Prints 'riskplan-fpga-shim listening on HOST:PORT' once it listens; SIGTERM or SIGINT\n"
      "stop it, and it then reports what the device did on stderr.";
  riskplan::cmdline::ParseCommandLine(argc, argv, help);
  return riskplan::accel::Main();
}
