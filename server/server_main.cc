// riskplan-server: the riskplan.v1.Planner gRPC service.
//
// Loads its maps once, serves until SIGTERM or SIGINT, then drains: health
// turns NOT_SERVING, new calls get UNAVAILABLE, running plans end with their
// best trajectory within --grace_period_ms, and the process exits 0.
#include <signal.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <thread>

#include "absl/flags/flag.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "absl/strings/string_view.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "accel/engine_metrics.h"
#include "accel/risk_engine.h"
#include "cmdline/help.h"
#include "core/planners/planner.h"
#include "grpcpp/ext/proto_server_reflection_plugin.h"
#include "grpcpp/grpcpp.h"
#include "grpcpp/health_check_service_interface.h"
#include "net/net.h"
#include "net/tls_context.h"
#include "server/observability/accel_metrics.h"
#include "server/observability/cache_metrics.h"
#include "server/security/connection_acceptor.h"
#include "server/observability/grpc_log.h"
#include "server/models/map_registry.h"
#include "server/observability/metrics.h"
#include "server/models/model_cache.h"
#include "server/planner_service.h"
#include "server/observability/rpc_log.h"
#include "server/security/server_security.h"

ABSL_FLAG(std::string, listen, "0.0.0.0:50051",
          "Address to serve on, HOST:PORT. Port 0 picks a free port; the line "
          "'riskplan-server listening on HOST:PORT' on stdout gives the real one.");
ABSL_FLAG(std::string, maps, "",
          "Directory whose sub-directories are map bundles (docs/map-bundle.md); every bundle "
          "is loaded at start-up. Empty: the built-in demo-city.");
ABSL_FLAG(double, demo_city_size_m, 8000.0,
          "Side of the built-in demo-city when --maps is empty, m (smaller: faster start, "
          "same layout scaled down)");
ABSL_FLAG(int, plan_threads, 0, "Planners running at once (0: one per CPU core)");
ABSL_FLAG(int, max_running_plans, 0,
          "Plans admitted at once, planning or waiting for a planning thread; one more gets "
          "RESOURCE_EXHAUSTED at once (0: twice --plan_threads)");
ABSL_FLAG(int, fleet_plan_slots, 0,
          "PlanFleet: mission groups planning at once, each also taking one of "
          "--max_running_plans (0: --plan_threads, at most --max_running_plans)");
ABSL_FLAG(int, max_fleet_missions, 256,
          "PlanFleet: most missions in one request; more is INVALID_ARGUMENT");
ABSL_FLAG(int64_t, max_admitted_missions, 1024,
          "PlanFleet: missions admitted at once over every fleet, waiting or planning; a fleet "
          "whose missions do not fit gets RESOURCE_EXHAUSTED at once");
ABSL_FLAG(int64_t, goal_tree_cache_mb, 0,
          "PlanFleet: MB of RISK_RRT_STAR goal trees kept across requests, keyed by map, goal, "
          "model and planner parameters and seed, least recently used out (0: off, each "
          "request grows its trees from the goal; at most 65536)");
ABSL_FLAG(int, eval_threads, 0,
          "EvaluateRisk, GetMapLayer and GetRiskLayer workers (0: one per CPU core)");
ABSL_FLAG(int, max_queued_evals, 1024,
          "Evaluations waiting for a worker; one more gets RESOURCE_EXHAUSTED");
ABSL_FLAG(int64_t, max_plan_time_ms, 600000,
          "Largest PlanRequest.budget.time_ms, and the wall-time cap of every plan");
ABSL_FLAG(int64_t, default_plan_time_ms, 1000,
          "Time budget of a plan whose budget sets neither time_ms nor iterations");
ABSL_FLAG(int, max_waypoints, 10000, "Most points of an EvaluateRisk trajectory");
ABSL_FLAG(int, max_obstacle_points, 10000,
          "Most obstacle points of one PlanRequest (at most 100000; dynamic obstacles: 1000)");
ABSL_FLAG(int64_t, max_eval_samples, 2000000,
          "Most samples (length / sample_step_m) of one EvaluateRisk trajectory");
ABSL_FLAG(int64_t, max_response_samples, 200000,
          "Most samples an EvaluateRisk response returns with include_samples");
ABSL_FLAG(int64_t, max_edge_samples, riskplan::kDefaultMaxEdgeSamples,
          "Most samples one edge of a plan may need, projected from the request before it is "
          "queued (map diagonal, turn radius, climbs, sample_step_m); more: INVALID_ARGUMENT");
ABSL_FLAG(int64_t, max_risk_layer_evaluations, int64_t{1} << 24,
          "Most configuration risks one GetRiskLayer may compute (cells, times the heading bins "
          "for the maximum over headings); larger layers are refused before any is computed");
ABSL_FLAG(int64_t, max_table_bytes, int64_t{512} << 20,
          "Largest impact table a request's model parameters may build, bytes (the default "
          "parameters' is about 34 MB on a 5 m map); larger: INVALID_ARGUMENT");
ABSL_FLAG(int, max_request_bytes, 4 << 20,
          "Largest request message, bytes; larger ones get RESOURCE_EXHAUSTED from gRPC");
ABSL_FLAG(int, model_cache_size, 4,
          "Risk models kept for overridden model parameters (each about 25 MB on an 8 km map)");
ABSL_FLAG(int, feasibility_cache_size, 8,
          "Two-tier feasibility checkers kept for EvaluateRisk (each about 8 bytes per map cell: "
          "20 MB on an 8 km map)");
ABSL_FLAG(int64_t, grace_period_ms, 10000,
          "On SIGTERM/SIGINT: time running plans get to finish; the last second of it (or "
          "its last half, if shorter) is left for stopping them and sending their best "
          "trajectory");
ABSL_FLAG(int64_t, max_connection_age_ms, 0,
          "Close client connections after this age so that load rebalances across replicas "
          "(0: never)");
ABSL_FLAG(std::string, tls_cert, "",
          "TLS: the server's certificate chain (PEM, leaf first); with --tls_key the port speaks "
          "TLS only. Re-read every --tls_reload_s; rotate by swapping its directory "
          "(docs/security.md)");
ABSL_FLAG(std::string, tls_key, "", "TLS: the private key of --tls_cert (PEM, unencrypted)");
ABSL_FLAG(std::string, tls_client_ca, "",
          "Mutual TLS: CA bundle (PEM) that must have signed every client's certificate; "
          "clients without one are refused");
ABSL_FLAG(std::string, tls_crl_dir, "",
          "Mutual TLS: directory of certificate revocation lists named by hash (openssl rehash); "
          "a revoked client certificate is refused");
ABSL_FLAG(int, tls_reload_s, 10,
          "TLS: seconds between reads of --tls_cert, --tls_key and --tls_client_ca (a rotated "
          "certificate is served to new connections within this time)");
ABSL_FLAG(std::string, token_file, "",
          "Bearer tokens: file of 'SHA256_HEX IDENTITY ROLE' lines (roles viewer, planner, "
          "operator; docs/security.md); calls without a listed token get UNAUTHENTICATED, calls "
          "beyond their role PERMISSION_DENIED. Re-read when it changes");
ABSL_FLAG(bool, allow_plaintext, false,
          "Serve plaintext on a --listen address that is not loopback (without TLS flags the "
          "server refuses to, so that plaintext is a decision)");
ABSL_FLAG(std::string, health_listen, "",
          "Also serve grpc.health.v1.Health alone, plaintext and without tokens, on HOST:PORT "
          "(for Kubernetes' gRPC probes, which speak no TLS; port 0 picks one, logged as event "
          "health_listening). Empty: off");
ABSL_FLAG(std::string, metrics_listen, "",
          "Serve Prometheus metrics at http://HOST:PORT/metrics (empty: off)");
ABSL_FLAG(bool, rpc_log, true, "Log one JSON line per RPC on stderr");
ABSL_FLAG(int, cpu_workers, 0,
          "Accelerator engine: CPU worker threads for risk batches (0 and no --fpga_shims: each "
          "plan and evaluation computes its own risks on its thread, as without an engine)");
ABSL_FLAG(std::string, fpga_shims, "",
          "Accelerator engine: riskplan-fpga-shim endpoints HOST:PORT,... (docs/shim-protocol.md); "
          "their workers' states are logged (event accel_worker) and exported as "
          "riskplan_accel_* metrics");
ABSL_FLAG(std::string, fpga_tls_ca, "",
          "Accelerator engine: TLS to the shims; the CA that signed their certificates (any "
          "--fpga_tls_* flag turns TLS on; plaintext to a shim that is not on loopback needs "
          "--allow_plaintext)");
ABSL_FLAG(std::string, fpga_tls_cert, "",
          "Accelerator engine: this server's client certificate for the shims (PEM; they "
          "require one)");
ABSL_FLAG(std::string, fpga_tls_key, "", "Accelerator engine: the private key of --fpga_tls_cert");
ABSL_FLAG(std::string, fpga_tls_server_name, "",
          "Accelerator engine: the name the shims' certificates must carry (default: each "
          "endpoint's host)");
ABSL_FLAG(bool, accel_caller_runs, true,
          "Accelerator engine: callers compute chunks of their own batches too (false: every "
          "chunk goes to the workers and boards)");
ABSL_FLAG(int, risk_cache_mb, 64,
          "Accelerator engine: bound of the kernel-site cache (exact and float32 results kept "
          "apart), MiB");
ABSL_FLAG(std::string, cpu_kernel, "exact",
          "Accelerator engine: the CPU kernel's arithmetic. exact: bit for bit riskplan-tool's "
          "(plans are reproducible against it); float32: EWMM sums in float32 with fused "
          "multiply-add, within 1e-5 relative of exact (docs/risk-model.md), faster. float32 "
          "starts the engine even without --cpu_workers (callers compute)");
ABSL_FLAG(int, prepared_map_cache_mb, 256,
          "Accelerator engine: bound of the CPU kernel's copies of the maps' layers on huge "
          "pages (8 bytes per padded cell: 24 MB for an 8 km map; a map that does not fit is "
          "read from its own layers), MiB");
ABSL_FLAG(int, blob_cache_mb, 256,
          "Accelerator engine: bound of the map and kernel blobs kept for uploads to FPGA "
          "boards (49 MB for an 8 km map with the default parameters; a model whose blob "
          "does not fit is left to the CPU), MiB");
ABSL_FLAG(int, kernel_weights_cache_mb, 128,
          "Accelerator engine: bound of the CPU kernel's aligned weight copies (one per impact "
          "table in use: 34 MB for the exact kernel, 19 MB for float32 with the default "
          "parameters), MiB");

namespace riskplan::server {
namespace {

// The goal tree cache's largest size: 64 GiB, beyond any replica's memory.
constexpr int64_t kMaxGoalTreeCacheMb = 65536;

constexpr char kUsage[] =
    "risk-aware UAV trajectory planning over gRPC (riskplan.v1.Planner).\n"
    "\n"
    "  riskplan-server --listen=HOST:PORT [--maps=DIR] [flags]\n"
    "\n"
    "Serves PlanTrajectory, EvaluateRisk, ListMaps, GetMapLayer, GetRiskLayer and\n"
    "Ping, plus grpc.health.v1.Health and server reflection. Prints\n"
    "'riskplan-server listening on HOST:PORT' on stdout once it serves. On SIGTERM or\n"
    "SIGINT it drains (see --grace_period_ms) and exits 0. Exit code 1: cannot start\n"
    "(bad map bundle, address in use) or a flag unknown or malformed; 2: a flag's value\n"
    "out of range. See docs/api.md.";

// Each algorithm's planner parameters (PlanRequest.planner_params) with
// their defaults and ranges, read from the planners themselves so the help
// cannot fall behind them.
std::string PlannerParamsHelp() {
  std::string text =
      "Planner parameters (PlanRequest.planner_params, `riskplan plan --planner_params`):";
  for (PlannerAlgorithm algorithm : {PlannerAlgorithm::kRiskRrtStar, PlannerAlgorithm::kRrt,
                                     PlannerAlgorithm::kGenetic, PlannerAlgorithm::kHarmonic}) {
    text += absl::StrFormat("\n  %s:", PlannerAlgorithmName(algorithm));
    for (const PlannerParamInfo& p : PlannerParams(algorithm)) {
      text += absl::StrFormat("\n    %-20s default %g, range [%g, %g]: %s", p.name, p.default_value,
                              p.min_value, p.max_value, p.help);
    }
  }
  return text;
}

int Fail(int code, absl::string_view message) {
  std::fprintf(stderr, "riskplan-server: %.*s\n", static_cast<int>(message.size()), message.data());
  return code;
}

// What the flags ask for, once checked.
struct ServerConfig {
  ServiceOptions options;  // `engine` is set once the engine exists
  ServerSecurityOptions security;
  // --listen (HOST:PORT) and its HOST; --health_listen (empty: off).
  std::string listen, listen_host, health_listen;
  // TLS to the FPGA shims (--fpga_tls_*).
  net::TlsFiles shim_tls;
  std::string shim_tls_server_name;
  int64_t grace_ms = 0;
  accel::KernelPrecision cpu_kernel = accel::KernelPrecision::kExact;
};

// The service's options from the flags, with their "0: automatic" defaults
// resolved. Values out of range are clamped where a clamp is harmless (queue
// and point bounds); the rest is left to CheckConfig.
ServiceOptions ServiceOptionsFromFlags() {
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  ServiceOptions options;
  options.plan_threads = absl::GetFlag(FLAGS_plan_threads);
  if (options.plan_threads == 0) options.plan_threads = static_cast<int>(cores);
  // Twice the planning threads by default: at most one admitted plan waits
  // per thread, so it starts within about one plan's time; a client beyond
  // that is refused at once rather than queued without bound (docs/api.md).
  options.max_running_plans = absl::GetFlag(FLAGS_max_running_plans);
  if (options.max_running_plans == 0) options.max_running_plans = 2 * options.plan_threads;
  options.fleet_plan_slots = absl::GetFlag(FLAGS_fleet_plan_slots);
  if (options.fleet_plan_slots == 0) {
    options.fleet_plan_slots = std::min(options.plan_threads, options.max_running_plans);
  }
  options.max_admitted_missions = absl::GetFlag(FLAGS_max_admitted_missions);
  options.limits.max_fleet_missions =
      static_cast<size_t>(std::max(0, absl::GetFlag(FLAGS_max_fleet_missions)));
  options.eval_threads = absl::GetFlag(FLAGS_eval_threads);
  if (options.eval_threads == 0) options.eval_threads = static_cast<int>(cores);
  options.max_queued_evals =
      static_cast<size_t>(std::max(1, absl::GetFlag(FLAGS_max_queued_evals)));
  options.limits.max_plan_time_ms = absl::GetFlag(FLAGS_max_plan_time_ms);
  options.limits.default_plan_time_ms = absl::GetFlag(FLAGS_default_plan_time_ms);
  options.limits.max_waypoints =
      static_cast<size_t>(std::max(2, absl::GetFlag(FLAGS_max_waypoints)));
  // Never above kMaxObstaclePoints, the most a planner accepts, whatever the
  // flag says.
  options.limits.max_obstacle_points =
      std::min(kMaxObstaclePoints,
               static_cast<size_t>(std::max(0, absl::GetFlag(FLAGS_max_obstacle_points))));
  options.limits.max_eval_samples = absl::GetFlag(FLAGS_max_eval_samples);
  options.limits.max_response_samples = absl::GetFlag(FLAGS_max_response_samples);
  options.limits.max_edge_samples = absl::GetFlag(FLAGS_max_edge_samples);
  options.limits.max_risk_layer_evaluations = absl::GetFlag(FLAGS_max_risk_layer_evaluations);
  options.limits.max_table_bytes =
      static_cast<size_t>(std::max<int64_t>(0, absl::GetFlag(FLAGS_max_table_bytes)));
  return options;
}

// Every flag check, in a fixed order (the first failure is the one printed).
absl::StatusOr<ServerConfig> ConfigFromFlags() {
  ServerConfig config;
  config.options = ServiceOptionsFromFlags();
  const ServiceOptions& options = config.options;
  config.grace_ms = absl::GetFlag(FLAGS_grace_period_ms);
  if (options.plan_threads < 1 || options.max_running_plans < 1 || options.eval_threads < 1) {
    return absl::InvalidArgumentError(
        "--plan_threads, --max_running_plans and --eval_threads must be >= 0");
  }
  if (options.fleet_plan_slots < 1 || options.fleet_plan_slots > options.max_running_plans ||
      options.limits.max_fleet_missions < 1 || options.max_admitted_missions < 1 ||
      static_cast<int64_t>(options.limits.max_fleet_missions) > options.max_admitted_missions) {
    return absl::InvalidArgumentError(
        "need 1 <= --fleet_plan_slots <= --max_running_plans (0: automatic) and 1 <= "
        "--max_fleet_missions <= --max_admitted_missions");
  }
  const int64_t goal_tree_cache_mb = absl::GetFlag(FLAGS_goal_tree_cache_mb);
  if (goal_tree_cache_mb < 0 || goal_tree_cache_mb > kMaxGoalTreeCacheMb) {
    return absl::InvalidArgumentError(
        absl::StrFormat("need 0 <= --goal_tree_cache_mb <= %d", kMaxGoalTreeCacheMb));
  }
  config.options.goal_tree_cache_bytes = static_cast<size_t>(goal_tree_cache_mb) << 20;
  if (options.limits.max_plan_time_ms < 1 || options.limits.default_plan_time_ms < 1 ||
      options.limits.default_plan_time_ms > options.limits.max_plan_time_ms) {
    return absl::InvalidArgumentError("need 1 <= --default_plan_time_ms <= --max_plan_time_ms");
  }
  if (config.grace_ms < 0 || absl::GetFlag(FLAGS_max_request_bytes) < 1024 ||
      absl::GetFlag(FLAGS_model_cache_size) < 0) {
    return absl::InvalidArgumentError(
        "--grace_period_ms and --model_cache_size must be >= 0, --max_request_bytes >= 1024");
  }
  if (!accel::ParseKernelPrecision(absl::GetFlag(FLAGS_cpu_kernel), &config.cpu_kernel)) {
    return absl::InvalidArgumentError(absl::StrFormat("--cpu_kernel=%s: must be exact or float32",
                                                      absl::GetFlag(FLAGS_cpu_kernel)));
  }
  for (const auto* flag : {&FLAGS_kernel_weights_cache_mb, &FLAGS_risk_cache_mb,
                           &FLAGS_prepared_map_cache_mb, &FLAGS_blob_cache_mb}) {
    if (absl::GetFlag(*flag) < 0) {
      return absl::InvalidArgumentError(
          absl::StrFormat("--%s must be >= 0", absl::GetFlagReflectionHandle(*flag).Name()));
    }
  }
  if (options.limits.max_edge_samples < 2 || absl::GetFlag(FLAGS_max_table_bytes) < 1 ||
      options.limits.max_eval_samples < 1 || options.limits.max_response_samples < 0) {
    return absl::InvalidArgumentError(
        "--max_edge_samples must be >= 2, --max_table_bytes and --max_eval_samples >= 1, "
        "--max_response_samples >= 0");
  }
  if (options.limits.max_risk_layer_evaluations < 1) {
    return absl::InvalidArgumentError("--max_risk_layer_evaluations must be >= 1");
  }
  if (absl::GetFlag(FLAGS_feasibility_cache_size) < 1) {
    return absl::InvalidArgumentError("--feasibility_cache_size must be >= 1");
  }
  config.options.max_cached_checkers =
      static_cast<size_t>(absl::GetFlag(FLAGS_feasibility_cache_size));
  config.security = ServerSecurityOptions{.tls_cert = absl::GetFlag(FLAGS_tls_cert),
                                          .tls_key = absl::GetFlag(FLAGS_tls_key),
                                          .tls_client_ca = absl::GetFlag(FLAGS_tls_client_ca),
                                          .tls_crl_dir = absl::GetFlag(FLAGS_tls_crl_dir),
                                          .tls_reload_s = absl::GetFlag(FLAGS_tls_reload_s),
                                          .token_file = absl::GetFlag(FLAGS_token_file),
                                          .allow_plaintext = absl::GetFlag(FLAGS_allow_plaintext)};
  config.listen = absl::GetFlag(FLAGS_listen);
  config.listen_host = config.listen.substr(0, config.listen.rfind(':'));
  config.health_listen = absl::GetFlag(FLAGS_health_listen);
  config.shim_tls = net::TlsFiles{.cert = absl::GetFlag(FLAGS_fpga_tls_cert),
                                  .key = absl::GetFlag(FLAGS_fpga_tls_key),
                                  .ca = absl::GetFlag(FLAGS_fpga_tls_ca),
                                  .crl = "",
                                  .flag_prefix = "fpga_"};
  config.shim_tls_server_name = absl::GetFlag(FLAGS_fpga_tls_server_name);
  return config;
}

// Blocks SIGTERM and SIGINT in the calling thread and, because a new thread
// inherits its creator's mask, in every thread started after this: only the
// main thread's sigwait() (WaitAndDrain) ever sees them, so the drain runs as
// ordinary code, with no async-signal-safety rules. Call before any thread
// starts (map loading, the engine, the metrics server and gRPC all start some).
sigset_t BlockStopSignals() {
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGTERM);
  sigaddset(&stop_signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  return stop_signals;
}

// The maps and their default risk models, built before the server listens so
// that the first request finds them ready and a bad bundle stops start-up.
struct LoadedMaps {
  std::unique_ptr<MapRegistry> registry;
  std::unique_ptr<RiskModelCache> models;  // reads `registry`: declared after it
};

absl::StatusOr<LoadedMaps> LoadMaps(const RequestLimits& limits) {
  const absl::Time load_start = absl::Now();
  const std::string maps_dir = absl::GetFlag(FLAGS_maps);
  absl::StatusOr<std::unique_ptr<MapRegistry>> registry =
      maps_dir.empty()
          ? MapRegistry::DemoCity(DemoCityOptions{.size_m = absl::GetFlag(FLAGS_demo_city_size_m)})
          : MapRegistry::LoadDirectory(maps_dir);
  if (!registry.ok()) return registry.status();
  absl::StatusOr<std::unique_ptr<RiskModelCache>> models = RiskModelCache::Create(
      **registry, static_cast<size_t>(absl::GetFlag(FLAGS_model_cache_size)), BuildLimits(limits));
  if (!models.ok()) return models.status();
  LogEvent("maps_loaded", absl::StrFormat("maps=[%s] bytes=%d seconds=%.2f",
                                          (*registry)->NameList(), (*registry)->MemoryBytes(),
                                          absl::ToDoubleSeconds(absl::Now() - load_start)));
  return LoadedMaps{*std::move(registry), *std::move(models)};
}

// The accelerator engine, only when a flag asks for one (null otherwise:
// every plan and evaluation computes its own risks, as without an engine).
absl::StatusOr<std::unique_ptr<accel::RiskEngine>> MakeEngine(const ServerConfig& config) {
  const accel::KernelPrecision cpu_kernel = config.cpu_kernel;
  const std::string shims = absl::GetFlag(FLAGS_fpga_shims);
  if (absl::GetFlag(FLAGS_cpu_workers) <= 0 && shims.empty() &&
      cpu_kernel == accel::KernelPrecision::kExact) {
    return nullptr;
  }
  accel::RiskEngineOptions engine_options;
  engine_options.cpu_workers = absl::GetFlag(FLAGS_cpu_workers);
  engine_options.caller_runs = absl::GetFlag(FLAGS_accel_caller_runs);
  engine_options.site_cache_bytes = static_cast<size_t>(absl::GetFlag(FLAGS_risk_cache_mb)) << 20;
  engine_options.kernel.precision = cpu_kernel;
  engine_options.kernel_weights_bytes =
      static_cast<size_t>(absl::GetFlag(FLAGS_kernel_weights_cache_mb)) << 20;
  engine_options.prepared_map_bytes =
      static_cast<size_t>(absl::GetFlag(FLAGS_prepared_map_cache_mb)) << 20;
  engine_options.blob_cache_bytes = static_cast<size_t>(absl::GetFlag(FLAGS_blob_cache_mb)) << 20;
  for (absl::string_view s : absl::StrSplit(shims, ',', absl::SkipWhitespace())) {
    engine_options.fpga_shims.emplace_back(s);
  }
  if (config.shim_tls.enabled() || !config.shim_tls_server_name.empty()) {
    absl::StatusOr<std::shared_ptr<net::TlsContext>> tls =
        net::TlsContext::ForClient(config.shim_tls);
    if (!tls.ok()) return tls.status();
    engine_options.fpga.client.tls = *std::move(tls);
    engine_options.fpga.client.tls_server_name = config.shim_tls_server_name;
  } else if (!config.security.allow_plaintext) {
    for (const std::string& endpoint : engine_options.fpga_shims) {
      std::string host;
      int port = 0;
      if (net::SplitHostPort(endpoint, &host, &port).ok() && !net::IsLoopbackHost(host)) {
        return absl::InvalidArgumentError(absl::StrFormat(
            "--fpga_shims: %s is not on loopback and no --fpga_tls_* flags were given: "
            "plaintext to it needs --allow_plaintext (docs/security.md)",
            endpoint));
      }
    }
  }
  // Worker state changes (a board going down, coming back) go to the same
  // structured log as the RPCs, so one stream tells what happened when.
  engine_options.on_worker_event = [](const accel::WorkerEvent& e) {
    LogEvent("accel_worker", accel::WorkerEventJson(e));
  };
  absl::StatusOr<std::unique_ptr<accel::RiskEngine>> engine =
      accel::RiskEngine::Create(engine_options);
  if (!engine.ok()) return engine.status();
  LogEvent("accel_engine",
           absl::StrFormat("cpu_workers=%d fpga_shims=[%s] fpga_tls=%s caller_runs=%d cpu_kernel=%s",
                           engine_options.cpu_workers, shims,
                           engine_options.fpga.client.tls != nullptr ? "on" : "off",
                           engine_options.caller_runs, accel::KernelPrecisionName(cpu_kernel)));
  return engine;
}

// The engine's metrics, and /metrics over HTTP with --metrics_listen.
absl::Status StartMetrics(accel::RiskEngine* engine, ServerMetrics& metrics) {
  if (engine != nullptr) metrics.AddCollectable(std::make_shared<AccelMetrics>(engine));
  const std::string address = absl::GetFlag(FLAGS_metrics_listen);
  if (address.empty()) return absl::OkStatus();
  absl::StatusOr<std::string> bound = metrics.Expose(address);
  if (!bound.ok()) return bound.status();
  LogEvent("metrics_listening", *bound);
  return absl::OkStatus();
}

// The gRPC server, serving `service`, health and reflection on the
// connections `acceptor` accepts (ConnectionAcceptor: it survives running out
// of file descriptors, which gRPC's own listener does not).
struct Serving {
  std::unique_ptr<grpc::Server> server;
  // Health alone, plaintext (--health_listen); null when off.
  std::unique_ptr<grpc::Server> health_server;
  std::string host;  // of --listen
  int port = 0;      // the bound one (--listen may ask for port 0)
  // Declared after the server, so destroyed before it: no connection is
  // handed to a server that is gone.
  std::unique_ptr<ConnectionAcceptor> acceptor;
};

// Every health service the process serves (the main port's, and the health
// port's when there is one). At start each name is registered SERVING; the
// drain turns them all NOT_SERVING in one call, which gRPC's default health
// service does under its one lock: a client that has seen one name change
// (a watch on "") finds the other changed too. Two calls, one per name, left
// a window in which a Check of "riskplan.v1.Planner" still answered SERVING
// after a watch of "" had read NOT_SERVING (ShutdownTest under ASan in CI).
void SetHealth(const Serving& serving, bool serving_status) {
  for (grpc::Server* server : {serving.server.get(), serving.health_server.get()}) {
    if (server == nullptr) continue;
    grpc::HealthCheckServiceInterface* health = server->GetHealthCheckService();
    if (serving_status) {
      health->SetServingStatus("", true);
      health->SetServingStatus("riskplan.v1.Planner", true);
    } else {
      health->SetServingStatus(false);
    }
  }
}

// The plaintext health port: a server of its own, with no Planner service,
// so that nothing but health is ever served without TLS and tokens.
absl::StatusOr<std::unique_ptr<grpc::Server>> StartHealthServer(const std::string& address) {
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort(address, grpc::InsecureServerCredentials(), &port);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  if (server == nullptr || port == 0) {
    return absl::UnavailableError(
        absl::StrFormat("cannot start: cannot listen on --health_listen=%s", address));
  }
  LogEvent("health_listening",
           absl::StrFormat("%s:%d", address.substr(0, address.rfind(':')), port));
  return server;
}

absl::StatusOr<Serving> BuildAndStart(const ServerConfig& config, PlannerService& service,
                                      ServerMetrics& metrics, const ServerSecurity& security) {
  const std::string& listen = config.listen;
  absl::StatusOr<std::unique_ptr<ConnectionAcceptor>> acceptor = ConnectionAcceptor::Listen(listen);
  if (!acceptor.ok()) {
    return absl::UnavailableError(absl::StrFormat("cannot start: cannot listen on --listen=%s: %s",
                                                  listen, acceptor.status().message()));
  }
  // Both must be set before the builder is created: they install themselves
  // as builder plugins.
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  Serving serving;
  std::unique_ptr<grpc::experimental::ExternalConnectionAcceptor> connections =
      builder.experimental().AddExternalConnectionAcceptor(
          grpc::ServerBuilder::experimental_type::ExternalConnectionType::FROM_FD,
          security.credentials);
  builder.SetMaxReceiveMessageSize(absl::GetFlag(FLAGS_max_request_bytes));
  // Responses are bounded by the request limits (samples, tree edges, layer
  // side); 64 MiB is the client library's receive limit too.
  builder.SetMaxSendMessageSize(64 << 20);
  if (const int64_t age_ms = absl::GetFlag(FLAGS_max_connection_age_ms); age_ms > 0) {
    builder.AddChannelArgument(GRPC_ARG_MAX_CONNECTION_AGE_MS, static_cast<int>(age_ms));
  }
  builder.RegisterService(&service);
  serving.server = builder.BuildAndStart();
  if (serving.server == nullptr) {
    return absl::UnavailableError(
        absl::StrFormat("cannot start: gRPC did not start on --listen=%s", listen));
  }
  serving.acceptor = *std::move(acceptor);
  serving.acceptor->Start(std::move(connections), [&metrics] { metrics.RecordAcceptError(); });
  if (!config.health_listen.empty()) {
    absl::StatusOr<std::unique_ptr<grpc::Server>> health_server =
        StartHealthServer(config.health_listen);
    if (!health_server.ok()) return health_server.status();
    serving.health_server = *std::move(health_server);
  }
  SetHealth(serving, true);
  serving.host = config.listen_host;
  serving.port = serving.acceptor->port();
  return serving;
}

// The readiness line on stdout (scripts and tests wait for it, and read the
// port from it), then the same as a log event.
void AnnounceServing(const Serving& serving, const ServiceOptions& options) {
  std::printf("riskplan-server listening on %s:%d\n", serving.host.c_str(), serving.port);
  std::fflush(stdout);
  LogEvent("serving",
           absl::StrFormat("address=%s:%d plan_threads=%d max_running_plans=%d eval_threads=%d",
                           serving.host, serving.port, options.plan_threads,
                           options.max_running_plans, options.eval_threads));
}

// How long the orderly exit after a completed drain may take (destructors,
// freeing the maps, a sanitizer's leak check) before the watchdog ends it.
constexpr absl::Duration kTeardownAllowance = absl::Seconds(10);

// Ends the process with exit code 1 if it still runs at a deadline: first
// the drain's (drain_timeout), then, once the drain is done, the exit's
// (teardown_timeout). One detached thread, started at SIGTERM.
class ExitWatchdog {
 public:
  static void Start(absl::Time drain_deadline) {
    deadline_ns_.store(absl::ToUnixNanos(drain_deadline));
    std::thread([] {
      for (;;) {
        const absl::Time deadline = absl::FromUnixNanos(deadline_ns_.load());
        const absl::Time now = absl::Now();
        if (now >= deadline) break;
        absl::SleepFor(std::min(deadline - now, absl::Milliseconds(200)));
      }
      if (tearing_down_.load()) {
        LogEvent("teardown_timeout", "the exit after the drain is taking too long; exiting");
      } else {
        LogEvent("drain_timeout", "work still running after the grace period; exiting");
      }
      std::_Exit(1);
    }).detach();
  }
  static void Teardown(absl::Time deadline) {
    tearing_down_.store(true);
    deadline_ns_.store(absl::ToUnixNanos(deadline));
  }

 private:
  static inline std::atomic<int64_t> deadline_ns_{0};
  static inline std::atomic<bool> tearing_down_{false};
};

// Waits for SIGTERM or SIGINT, then drains: refuse new work, let running
// plans use the grace period, then stop them so that they send their best
// trajectory before the server stops.
void WaitAndDrain(const sigset_t& stop_signals, PlannerService& service, Serving& serving,
                  int64_t grace_ms) {
  grpc::Server& server = *serving.server;
  int signal_number = 0;
  sigwait(&stop_signals, &signal_number);

  const absl::Time drain_start = absl::Now();
  const absl::Duration grace = absl::Milliseconds(grace_ms);
  // Stopped plans still need time to return and write their final message.
  const absl::Duration stop_margin = std::min(absl::Seconds(1), grace / 2);
  // Draining first: a client that sees NOT_SERVING is sure to be refused.
  service.StartDraining();
  SetHealth(serving, false);
  ActivePlans& plans = service.active_plans();
  LogEvent("draining", absl::StrFormat("signal=%d running_plans=%d grace_ms=%d", signal_number,
                                       plans.running(), grace_ms));
  // A last resort, in case some work ignores its stop (a bug): the process
  // ends two seconds after the grace period if the drain is still running,
  // so that a stuck thread cannot hold a terminating pod. Exit code 1 says
  // the drain did not complete.
  ExitWatchdog::Start(drain_start + grace + absl::Seconds(2));
  if (!plans.WaitUntilIdle(drain_start + grace - stop_margin)) {
    LogEvent("stopping_plans", absl::StrFormat("running_plans=%d", plans.running()));
    plans.StopAll();
  }
  // Evaluations (and model builds) get as long as plans, then are stopped:
  // they answer UNAVAILABLE at once, and no worker is left computing for a
  // call that gRPC's shutdown would cancel anyway.
  if (!service.open_calls().WaitUntilNone(drain_start + grace - stop_margin)) {
    service.StopEvaluations();
  }
  plans.WaitUntilIdle(drain_start + grace);
  // Final messages still in flight and evaluations get what is left of the
  // grace period; once none is open, gRPC is shut down at once (calls still
  // open after the grace period are cancelled). Waiting on gRPC's Shutdown
  // deadline alone would also wait for idle clients to acknowledge GOAWAY.
  const bool none_open = service.open_calls().WaitUntilNone(drain_start + grace);
  // New connections are refused from here on (a connection handed to gRPC
  // after its shutdown began would be dropped without being closed).
  serving.acceptor->Stop();
  server.Shutdown(absl::ToChronoTime(
      none_open ? absl::Now()
                : std::max(drain_start + grace, absl::Now() + absl::Milliseconds(200))));
  if (serving.health_server != nullptr) serving.health_server->Shutdown(absl::ToChronoTime(absl::Now()));
  LogEvent("stopped",
           absl::StrFormat("seconds=%.3f", absl::ToDoubleSeconds(absl::Now() - drain_start)));
  // The drain is done; what is left is the orderly exit (destructors join
  // the workers, the maps are freed), which gets its own allowance rather
  // than the drain's: a drain that ended in milliseconds left the exit
  // seconds, and under a sanitizer on a loaded machine (its leak check
  // scans the heap at exit) that was not always enough.
  ExitWatchdog::Teardown(absl::Now() + kTeardownAllowance);
}

// Exit codes: 2 for bad flags, 1 when the server cannot start, 0 after a
// drain. Locals are destroyed in the reverse order of their declaration,
// which is the order needed: the gRPC server before the service, the service
// before the metrics and the engine (its calls use both), the metrics before
// the engine (AccelMetrics reads it at every scrape), all before the maps.
int Main() {
  absl::StatusOr<ServerConfig> config = ConfigFromFlags();
  if (!config.ok()) return Fail(2, config.status().message());
  SetRpcLogEnabled(absl::GetFlag(FLAGS_rpc_log));
  RouteProtobufLogs();
  InstallGrpcLogHook();
  const sigset_t stop_signals = BlockStopSignals();
  // Before the maps load (seconds): a bad certificate, key or token file
  // stops start-up at once, naming the file.
  absl::StatusOr<ServerSecurity> security =
      MakeServerSecurity(config->security, config->listen_host);
  if (!security.ok()) {
    return Fail(1, absl::StrFormat("cannot start: %s", security.status().message()));
  }
  config->options.authorizer = security->authorizer;
  LogEvent("security", security->summary);

  absl::StatusOr<LoadedMaps> maps = LoadMaps(config->options.limits);
  if (!maps.ok()) return Fail(1, absl::StrFormat("cannot start: %s", maps.status().message()));
  absl::StatusOr<std::unique_ptr<accel::RiskEngine>> engine = MakeEngine(*config);
  if (!engine.ok()) {
    return Fail(1,
                absl::StrFormat("cannot start: accelerator engine: %s", engine.status().message()));
  }
  config->options.engine = engine->get();
  ServerMetrics metrics;
  if (absl::Status s = StartMetrics(engine->get(), metrics); !s.ok()) return Fail(1, s.message());

  PlannerService service(*maps->registry, *maps->models, metrics, config->options);
  metrics.AddCollectable(std::make_shared<CacheMetrics>(
      maps->models.get(), static_cast<size_t>(absl::GetFlag(FLAGS_model_cache_size)),
      service.checkers(), service.goal_trees()));
  absl::StatusOr<Serving> serving = BuildAndStart(*config, service, metrics, *security);
  if (!serving.ok()) return Fail(1, serving.status().message());
  AnnounceServing(*serving, config->options);
  WaitAndDrain(stop_signals, service, *serving, config->grace_ms);
  return 0;
}

}  // namespace
}  // namespace riskplan::server

int main(int argc, char** argv) {
  riskplan::cmdline::ProgramHelp help;
  help.program = "riskplan-server";
  help.usage = riskplan::server::kUsage;
  help.footer = riskplan::server::PlannerParamsHelp();
  riskplan::cmdline::ParseCommandLine(argc, argv, help);
  return riskplan::server::Main();
}
