// riskplan-server's flags and their translation into a ServerConfig.
#include "server/server_flags.h"

#include <algorithm>
#include <cstdint>
#include <string>
#include <thread>

#include "absl/flags/flag.h"
#include "absl/status/status.h"
#include "absl/strings/str_format.h"
#include "core/planners/planner.h"

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
ABSL_FLAG(int, max_flight_zones, 64,
          "Fly: most temporary no-fly zones a session holds at once, [1, 10000]");
ABSL_FLAG(int, max_zone_vertices, 64, "Fly: most vertices of a zone's polygon, [3, 10000]");
ABSL_FLAG(double, max_flight_report_hz, 50,
          "Fly: most position reports per second of flight time (bursts of 10), (0, 1000]");
ABSL_FLAG(int64_t, max_replan_time_ms, 10000,
          "Fly: largest replanning budget a session may ask for, ms, [1, --max_plan_time_ms]");
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
  options.flight_limits.zones.max_zones =
      static_cast<size_t>(std::max(0, absl::GetFlag(FLAGS_max_flight_zones)));
  options.flight_limits.zones.max_vertices =
      static_cast<size_t>(std::max(0, absl::GetFlag(FLAGS_max_zone_vertices)));
  options.flight_limits.max_report_hz = absl::GetFlag(FLAGS_max_flight_report_hz);
  options.flight_limits.max_replan_time_ms = absl::GetFlag(FLAGS_max_replan_time_ms);
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

// ConfigFromFlags' first checks, in order: the pools, the fleet bounds, the
// goal tree cache, the plan times, the grace period and the request and
// model-cache bounds.
absl::Status CheckServiceFlags(ServerConfig& config) {
  const ServiceOptions& options = config.options;
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
  const FlightLimits& flight = options.flight_limits;
  if (flight.zones.max_zones < 1 || flight.zones.max_zones > 10000 ||
      flight.zones.max_vertices < 3 || flight.zones.max_vertices > 10000 ||
      !(flight.max_report_hz > 0.0 && flight.max_report_hz <= 1000.0) ||
      flight.max_replan_time_ms < 1 ||
      flight.max_replan_time_ms > options.limits.max_plan_time_ms) {
    return absl::InvalidArgumentError(
        "need --max_flight_zones in [1, 10000], --max_zone_vertices in [3, 10000], "
        "--max_flight_report_hz in (0, 1000] and --max_replan_time_ms in [1, --max_plan_time_ms]");
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
  return absl::OkStatus();
}

// ConfigFromFlags' last checks, in order: the CPU kernel and the engine's
// cache bounds, the sample and size limits, the feasibility cache.
absl::Status CheckEngineAndLimitFlags(ServerConfig& config) {
  const ServiceOptions& options = config.options;
  if (!accel::ParseKernelPrecision(absl::GetFlag(FLAGS_cpu_kernel), &config.engine.cpu_kernel)) {
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
  return absl::OkStatus();
}

// The engine's flags but --cpu_kernel (CheckEngineAndLimitFlags reads it);
// read after the checks, so the cache bounds are >= 0.
void ReadEngineFlags(EngineConfig& engine) {
  engine.cpu_workers = absl::GetFlag(FLAGS_cpu_workers);
  engine.fpga_shims = absl::GetFlag(FLAGS_fpga_shims);
  engine.caller_runs = absl::GetFlag(FLAGS_accel_caller_runs);
  engine.site_cache_bytes = static_cast<size_t>(absl::GetFlag(FLAGS_risk_cache_mb)) << 20;
  engine.kernel_weights_bytes = static_cast<size_t>(absl::GetFlag(FLAGS_kernel_weights_cache_mb))
                                << 20;
  engine.prepared_map_bytes = static_cast<size_t>(absl::GetFlag(FLAGS_prepared_map_cache_mb)) << 20;
  engine.blob_cache_bytes = static_cast<size_t>(absl::GetFlag(FLAGS_blob_cache_mb)) << 20;
  engine.shim_tls = net::TlsFiles{.cert = absl::GetFlag(FLAGS_fpga_tls_cert),
                                  .key = absl::GetFlag(FLAGS_fpga_tls_key),
                                  .ca = absl::GetFlag(FLAGS_fpga_tls_ca),
                                  .crl = "",
                                  .flag_prefix = "fpga_"};
  engine.shim_tls_server_name = absl::GetFlag(FLAGS_fpga_tls_server_name);
}

// The flags that need no check here: addresses, security (checked by
// MakeServerSecurity at start-up), maps, logging.
void ReadServingFlags(ServerConfig& config) {
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
  config.metrics_listen = absl::GetFlag(FLAGS_metrics_listen);
  config.maps_dir = absl::GetFlag(FLAGS_maps);
  config.demo_city_size_m = absl::GetFlag(FLAGS_demo_city_size_m);
  // Checked >= 0 by CheckServiceFlags.
  config.model_cache_size = static_cast<size_t>(absl::GetFlag(FLAGS_model_cache_size));
  config.max_request_bytes = absl::GetFlag(FLAGS_max_request_bytes);
  config.max_connection_age_ms = absl::GetFlag(FLAGS_max_connection_age_ms);
  config.rpc_log = absl::GetFlag(FLAGS_rpc_log);
}

}  // namespace

absl::StatusOr<ServerConfig> ConfigFromFlags() {
  ServerConfig config;
  config.options = ServiceOptionsFromFlags();
  config.grace_ms = absl::GetFlag(FLAGS_grace_period_ms);
  if (absl::Status s = CheckServiceFlags(config); !s.ok()) return s;
  if (absl::Status s = CheckEngineAndLimitFlags(config); !s.ok()) return s;
  ReadEngineFlags(config.engine);
  ReadServingFlags(config);
  return config;
}

cmdline::ProgramHelp ServerHelp() {
  cmdline::ProgramHelp help;
  help.program = "riskplan-server";
  help.usage = kUsage;
  help.footer = PlannerParamsHelp();
  return help;
}

}  // namespace riskplan::server
