// riskplan-server's start-up and drain, step by step, each from a checked
// ServerConfig (server_flags.h): the stop signals, the maps, the accelerator
// engine, the metrics, the gRPC servers, the readiness line, then the wait
// for SIGTERM or SIGINT and the drain. server_main.cc calls them in order.
#ifndef RISKPLAN_SERVER_SERVER_STARTUP_H_
#define RISKPLAN_SERVER_SERVER_STARTUP_H_

#include <signal.h>

#include <cstdint>
#include <memory>
#include <string>
#include <thread>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "accel/risk_engine.h"
#include "grpcpp/grpcpp.h"
#include "server/models/map_registry.h"
#include "server/models/model_cache.h"
#include "server/observability/metrics.h"
#include "server/planner_service.h"
#include "server/security/connection_acceptor.h"
#include "server/security/reflection_service.h"
#include "server/security/server_security.h"
#include "server/server_flags.h"

namespace riskplan::server {

// Blocks SIGTERM and SIGINT in the calling thread and, because a new thread
// inherits its creator's mask, in every thread started after this: only the
// main thread's sigwait() (WaitAndDrain) ever sees them, so the drain runs as
// ordinary code, with no async-signal-safety rules. Call before any thread
// starts (map loading, the engine, the metrics server and gRPC all start some).
sigset_t BlockStopSignals();

// The maps and their default risk models, built before the server listens so
// that the first request finds them ready and a bad bundle stops start-up.
struct LoadedMaps {
  std::unique_ptr<MapRegistry> registry;
  std::unique_ptr<RiskModelCache> models;  // reads `registry`: declared after it
};

// --maps, or the built-in demo-city when it is empty; logs maps_loaded.
absl::StatusOr<LoadedMaps> LoadMaps(const ServerConfig& config);

// The accelerator engine, only when the config asks for one (null otherwise:
// every plan and evaluation computes its own risks, as without an engine).
// Plaintext to a shim off loopback needs --allow_plaintext.
absl::StatusOr<std::unique_ptr<accel::RiskEngine>> MakeEngine(const ServerConfig& config);

// The engine's metrics (when there is an engine), and /metrics over HTTP on
// `address` (empty: off).
absl::Status StartMetrics(accel::RiskEngine* engine, ServerMetrics& metrics,
                          const std::string& address);

// The gRPC server, serving `service`, health and reflection (riskplan's
// own, token-checked: server/security/reflection_service.h) on the connections `acceptor` accepts (ConnectionAcceptor: it survives running out
// of file descriptors, which gRPC's own listener does not).
// A completion queue that a thread of its own keeps polling. The health
// port's server has no service of its own (gRPC adds its health service at
// start), and gRPC builds no server without a polled queue; this one also
// carries gRPC's UNIMPLEMENTED answers to every other method there.
class PolledQueue {
 public:
  explicit PolledQueue(std::unique_ptr<grpc::ServerCompletionQueue> queue);
  // Shuts the queue down and waits for the thread: only after the server
  // that uses it has shut down (Serving declares it before the server).
  ~PolledQueue();

 private:
  std::unique_ptr<grpc::ServerCompletionQueue> queue_;
  std::thread thread_;
};

// The plaintext health port (--health_listen): gRPC's health service alone.
struct HealthPort {
  std::unique_ptr<PolledQueue> queue;    // declared first: destroyed after the server
  std::unique_ptr<grpc::Server> server;
};

struct Serving {
  // Registered on `server`: declared first, destroyed after it.
  std::unique_ptr<ReflectionService> reflection;
  std::unique_ptr<grpc::Server> server;
  // Health alone, plaintext (--health_listen); null when off.
  std::unique_ptr<HealthPort> health;
  std::string host;  // of --listen
  int port = 0;      // the bound one (--listen may ask for port 0)
  // Declared after the server, so destroyed before it: no connection is
  // handed to a server that is gone.
  std::unique_ptr<ConnectionAcceptor> acceptor;
};

// Listens on --listen (and --health_listen), starts gRPC and turns health
// SERVING. UNAVAILABLE, naming the address, when it cannot.
absl::StatusOr<Serving> BuildAndStart(const ServerConfig& config, PlannerService& service,
                                      ServerMetrics& metrics, const ServerSecurity& security);

// The readiness line on stdout (scripts and tests wait for it, and read the
// port from it), then the same as a log event.
void AnnounceServing(const Serving& serving, const ServiceOptions& options);

// Waits for SIGTERM or SIGINT, then drains: refuse new work, let running
// plans use the grace period, then stop them so that they send their best
// trajectory before the server stops. A watchdog ends the process with exit
// code 1 if the drain, or the exit after it, overruns.
void WaitAndDrain(const sigset_t& stop_signals, PlannerService& service, Serving& serving,
                  int64_t grace_ms);

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_SERVER_STARTUP_H_
