// Throughput and latency of risk batches through a local riskplan-fpga-shim
// (issue 5): a RiskEngine whose only worker is one board, by batch size, for
// the two access patterns (along trajectories, random), with
//   model     the fixed-point datapath in software (one lane), and
//   mmio      the mmio backend on the in-memory component model (8 lanes),
//             which also reports the component's cycle count: the time the
//             board itself would take at its clock (100 MHz).
// The shim runs in this process (the same ShimServer as the daemon) on
// 127.0.0.1:0; pass --shim=HOST:PORT to measure an external one instead.
// Latency is the wall time of one batch (Evaluate call); the machine is
// shared, so compare side by side in one run and quote medians.
//
// With --tls_dir=DIR (a PKI made by tests/integration/test_pki.sh, with
// shim.{pem,key} for 127.0.0.1 and client.{pem,key}, both of CA a:
// scripts/shim-tls-bench.sh makes one) the model backend's batches are also
// run over mutual TLS (tls:1), and BM_ShimConnect measures a connection with
// its HELLO exchange, plaintext against TLS (the handshake's cost).
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "accel/risk_engine.h"
#include "accel/shim/component_model.h"
#include "accel/shim/mmio_device.h"
#include "accel/shim/shim_server.h"
#include "accel/shim_client.h"
#include "bench/demo_city_configs.h"
#include "benchmark/benchmark.h"
#include "core/map/demo_city.h"
#include "net/tls_context.h"

namespace riskplan {
namespace {

std::string g_external_shim;
std::string g_tls_dir;

// The two ends' TLS from --tls_dir (null without it).
std::shared_ptr<net::TlsContext> ShimTls(bool listener) {
  if (g_tls_dir.empty()) return nullptr;
  const std::string d = g_tls_dir + "/";
  absl::StatusOr<std::shared_ptr<net::TlsContext>> tls =
      listener ? net::TlsContext::ForListener(
                     {.cert = d + "shim.pem", .key = d + "shim.key", .ca = d + "ca-a.pem"})
               : net::TlsContext::ForClient(
                     {.cert = d + "client.pem", .key = d + "client.key", .ca = d + "ca-a.pem"});
  if (!tls.ok()) {
    std::fprintf(stderr, "--tls_dir: %s\n", std::string(tls.status().message()).c_str());
    std::exit(1);
  }
  return *tls;
}

const std::shared_ptr<const RiskModel>& Model() {
  static const std::shared_ptr<const RiskModel> model = [] {
    auto map = MakeDemoCity();
    return *RiskModel::Create(*map, ModelParams{});
  }();
  return model;
}

std::vector<Pose> Configurations(bool along, size_t n) {
  return along ? bench::AlongTrajectories(*Model(), n) : bench::RandomConfigurations(*Model(), n);
}

// A shim (in-process unless --shim) and an engine using only it.
struct Setup {
  std::unique_ptr<accel::ShimServer> server;
  std::unique_ptr<accel::RiskEngine> engine;
  std::string endpoint;
};

Setup& SetupFor(bool mmio, bool tls = false) {
  static Setup setups[4];
  Setup& s = setups[(mmio ? 1 : 0) + (tls ? 2 : 0)];
  if (s.engine != nullptr) return s;
  s.endpoint = g_external_shim;
  if (s.endpoint.empty()) {
    std::unique_ptr<accel::EwmmDevice> device;
    if (mmio) {
      accel::ComponentConfig config;
      config.lanes = 8;
      device = *accel::MmioDevice::Open(std::make_unique<accel::ComponentModel>(config), {});
    } else {
      device = std::make_unique<accel::ModelDevice>(accel::NumberFormat::Board());
    }
    accel::ShimServerOptions shim_options;
    if (tls) shim_options.tls = ShimTls(/*listener=*/true);
    s.server = std::make_unique<accel::ShimServer>(std::move(device), shim_options);
    s.endpoint = *s.server->Start("127.0.0.1:0");
  }
  accel::RiskEngineOptions options;
  options.cpu_workers = 0;
  options.caller_runs = false;
  options.max_chunk_configs = 65536;
  options.min_chunk_configs = 65536;  // one chunk per batch: one EVAL
  options.fpga_shims = {s.endpoint};
  if (tls) options.fpga.client.tls = ShimTls(/*listener=*/false);
  s.engine = *accel::RiskEngine::Create(options);
  while (s.engine->Stats().fpga[0].state != accel::WorkerState::kUp) {
    absl::SleepFor(absl::Milliseconds(5));
  }
  // Warm up: the blobs are uploaded once.
  std::vector<Pose> one = Configurations(true, 10);
  std::vector<ConfigurationRisk> out(one.size());
  (void)s.engine->Evaluate(*Model(), one, out);
  return s;
}

// Args: batch size, pattern (1 along, 0 random), backend (0 model, 1 mmio).
void BM_ShimBatch(benchmark::State& state) {
  const size_t batch = static_cast<size_t>(state.range(0));
  const bool along = state.range(1) == 1;
  const bool mmio = state.range(2) == 1;
  const bool tls = state.range(3) == 1;
  if (tls && g_tls_dir.empty()) {
    state.SkipWithError("tls:1 needs --tls_dir");
    return;
  }
  Setup& s = SetupFor(mmio, tls);
  const std::vector<Pose> configs = Configurations(along, 65536);
  std::vector<ConfigurationRisk> out(batch);
  const accel::RiskEngineStats before = s.engine->Stats();
  size_t first = 0;
  int64_t batches = 0;
  for (auto _ : state) {
    if (first + batch > configs.size()) first = 0;
    if (!s.engine->Evaluate(*Model(), std::span<const Pose>(configs).subspan(first, batch), out)
             .ok()) {
      state.SkipWithError("Evaluate failed");
      return;
    }
    first += batch;
    ++batches;
  }
  const accel::RiskEngineStats after = s.engine->Stats();
  state.SetItemsProcessed(static_cast<int64_t>(batches * batch));
  const double cycles =
      static_cast<double>(after.fpga[0].device_cycles - before.fpga[0].device_cycles);
  if (mmio && batches > 0) {
    state.counters["cycles_per_risk"] = cycles / static_cast<double>(batches * batch);
    // What the component alone would sustain at 100 MHz.
    state.counters["board_risks_per_s_100MHz"] =
        1e8 * static_cast<double>(batches * batch) / cycles;
  }
}
BENCHMARK(BM_ShimBatch)
    ->ArgsProduct({{16, 256, 4096, 65536}, {1, 0}, {0}, {0, 1}})
    ->ArgsProduct({{256, 4096}, {1, 0}, {1}, {0}})
    ->ArgNames({"batch", "along", "mmio", "tls"})
    ->UseRealTime()
    ->Unit(benchmark::kMicrosecond);

// A connection to the model shim and its HELLO exchange: TCP alone (tls:0)
// or with the mutual TLS handshake (tls:1).
void BM_ShimConnect(benchmark::State& state) {
  const bool tls = state.range(0) == 1;
  if (tls && g_tls_dir.empty()) {
    state.SkipWithError("tls:1 needs --tls_dir");
    return;
  }
  Setup& s = SetupFor(/*mmio=*/false, tls);
  accel::ShimClientOptions options;
  if (tls) options.tls = ShimTls(/*listener=*/false);
  for (auto _ : state) {
    absl::StatusOr<std::unique_ptr<accel::ShimClient>> client =
        accel::ShimClient::Connect(s.endpoint, options);
    if (!client.ok()) {
      state.SkipWithError("connect failed");
      return;
    }
  }
}
BENCHMARK(BM_ShimConnect)->ArgsProduct({{0, 1}})->ArgNames({"tls"})->UseRealTime()->Unit(
    benchmark::kMicrosecond);

}  // namespace
}  // namespace riskplan

int main(int argc, char** argv) {
  // --shim is taken out of argv, so that Google Benchmark, which answers
  // --help (exit 0) with its own flags and refuses flags it does not know,
  // sees only its own.
  int kept = 1;
  for (int i = 1; i < argc; ++i) {
    if (std::strncmp(argv[i], "--shim=", 7) == 0) {
      riskplan::g_external_shim = argv[i] + 7;
    } else if (std::strncmp(argv[i], "--tls_dir=", 10) == 0) {
      riskplan::g_tls_dir = argv[i] + 10;
    } else {
      argv[kept++] = argv[i];
    }
  }
  argc = kept;
  benchmark::Initialize(&argc, argv, [] {
    benchmark::PrintDefaultHelp();
    std::fprintf(stdout,
                 "          [--shim=HOST:PORT] (a running riskplan-fpga-shim to measure instead "
                 "of one in this process)\n"
                 "          [--tls_dir=DIR] (test_pki.sh certificates: also measure over mutual "
                 "TLS)\n");
  });
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  return 0;
}
