// riskplan-server's command line: its flags (defined in server_flags.cc),
// its --help, and ServerConfig, what the flags ask for once checked.
//
// Only riskplan-server links this (library riskplan_server_main), so no other
// program or test finds these flags in its registry. Start-up
// (server_startup.h) reads the ServerConfig, never a flag.
#ifndef RISKPLAN_SERVER_SERVER_FLAGS_H_
#define RISKPLAN_SERVER_SERVER_FLAGS_H_

#include <cstddef>
#include <cstdint>
#include <string>

#include "absl/status/statusor.h"
#include "accel/risk_engine.h"
#include "net/tls_context.h"
#include "cmdline/help.h"
#include "server/planner_service.h"
#include "server/security/server_security.h"

namespace riskplan::server {

// The accelerator engine the flags ask for (--cpu_workers, --fpga_*,
// --cpu_kernel and the engine's cache bounds); MakeEngine builds it.
struct EngineConfig {
  int cpu_workers = 0;
  std::string fpga_shims;  // as given: HOST:PORT,...
  bool caller_runs = true;
  accel::KernelPrecision cpu_kernel = accel::KernelPrecision::kExact;
  size_t site_cache_bytes = 0;
  size_t kernel_weights_bytes = 0;
  size_t prepared_map_bytes = 0;
  size_t blob_cache_bytes = 0;
  // TLS to the FPGA shims (--fpga_tls_*).
  net::TlsFiles shim_tls;
  std::string shim_tls_server_name;
};

// What the flags ask for, once checked.
struct ServerConfig {
  ServiceOptions options;  // `engine` and `authorizer` are set at start-up
  ServerSecurityOptions security;
  // --listen (HOST:PORT) and its HOST; --health_listen and --metrics_listen
  // (empty: off).
  std::string listen, listen_host, health_listen, metrics_listen;
  // --maps (empty: the built-in demo-city, --demo_city_size_m on a side).
  std::string maps_dir;
  double demo_city_size_m = 0.0;
  size_t model_cache_size = 0;
  int max_request_bytes = 0;
  int64_t max_connection_age_ms = 0;  // 0: never
  bool rpc_log = true;
  int64_t grace_ms = 0;
  EngineConfig engine;
};

// Every flag, checked in a fixed order (the first failure is the one
// printed, and is INVALID_ARGUMENT), with the "0: automatic" defaults
// resolved. Call after cmdline::ParseCommandLine.
absl::StatusOr<ServerConfig> ConfigFromFlags();

// riskplan-server's --help: what it is, how to call it, and the planner
// parameters of every algorithm after the flags.
cmdline::ProgramHelp ServerHelp();

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_SERVER_FLAGS_H_
