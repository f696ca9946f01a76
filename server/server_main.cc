// riskplan-server: the riskplan.v1.Planner gRPC service.
//
// Loads its maps once, serves until SIGTERM or SIGINT, then drains: health
// turns NOT_SERVING, new calls get UNAVAILABLE, running plans end with their
// best trajectory within --grace_period_ms, and the process exits 0. The
// flags are in server_flags.h, the steps below in server_startup.h.
#include <signal.h>

#include <cstdio>
#include <memory>

#include "absl/status/statusor.h"
#include "absl/strings/str_format.h"
#include "absl/strings/string_view.h"
#include "cmdline/help.h"
#include "server/observability/cache_metrics.h"
#include "server/observability/grpc_log.h"
#include "server/observability/rpc_log.h"
#include "server/planner_service.h"
#include "server/security/server_security.h"
#include "server/server_flags.h"
#include "server/server_startup.h"

namespace riskplan::server {
namespace {

int Fail(int code, absl::string_view message) {
  std::fprintf(stderr, "riskplan-server: %.*s\n", static_cast<int>(message.size()), message.data());
  return code;
}

// Exit codes: 2 for bad flags, 1 when the server cannot start, 0 after a
// drain. Locals are destroyed in the reverse order of their declaration,
// which is the order needed: the gRPC server before the service, the service
// before the metrics and the engine (its calls use both), the metrics before
// the engine (AccelMetrics reads it at every scrape), all before the maps.
int Main() {
  absl::StatusOr<ServerConfig> config = ConfigFromFlags();
  if (!config.ok()) return Fail(2, config.status().message());
  SetRpcLogEnabled(config->rpc_log);
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

  absl::StatusOr<LoadedMaps> maps = LoadMaps(*config);
  if (!maps.ok()) return Fail(1, absl::StrFormat("cannot start: %s", maps.status().message()));
  absl::StatusOr<std::unique_ptr<accel::RiskEngine>> engine = MakeEngine(*config);
  if (!engine.ok()) {
    return Fail(1,
                absl::StrFormat("cannot start: accelerator engine: %s", engine.status().message()));
  }
  config->options.engine = engine->get();
  ServerMetrics metrics;
  if (absl::Status s = StartMetrics(engine->get(), metrics, config->metrics_listen); !s.ok()) {
    return Fail(1, s.message());
  }

  PlannerService service(*maps->registry, *maps->models, metrics, config->options);
  metrics.AddCollectable(std::make_shared<CacheMetrics>(
      maps->models.get(), config->model_cache_size, service.checkers(), service.goal_trees()));
  absl::StatusOr<Serving> serving = BuildAndStart(*config, service, metrics, *security);
  if (!serving.ok()) return Fail(1, serving.status().message());
  AnnounceServing(*serving, config->options);
  WaitAndDrain(stop_signals, service, *serving, config->grace_ms);
  return 0;
}

}  // namespace
}  // namespace riskplan::server

int main(int argc, char** argv) {
  riskplan::cmdline::ParseCommandLine(argc, argv, riskplan::server::ServerHelp());
  return riskplan::server::Main();
}
