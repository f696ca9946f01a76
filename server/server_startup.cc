#include "server/server_startup.h"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <thread>
#include <utility>
#include <vector>

#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "absl/strings/string_view.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "accel/engine_metrics.h"
#include "net/net.h"
#include "net/tls_context.h"
#include "grpcpp/health_check_service_interface.h"
#include "grpcpp/impl/server_builder_option.h"
#include "grpcpp/impl/server_builder_plugin.h"
#include "server/observability/accel_metrics.h"
#include "server/observability/rpc_log.h"

namespace riskplan::server {
namespace {

// Every health service the process serves (the main port's, and the health
// port's when there is one). At start each name is registered SERVING; the
// drain turns them all NOT_SERVING in one call, which gRPC's default health
// service does under its one lock: a client that has seen one name change
// (a watch on "") finds the other changed too. Two calls, one per name, left
// a window in which a Check of "riskplan.v1.Planner" still answered SERVING
// after a watch of "" had read NOT_SERVING (ShutdownTest under ASan in CI).
void SetHealth(const Serving& serving, bool serving_status) {
  for (grpc::Server* server :
       {serving.server.get(), serving.health ? serving.health->server.get() : nullptr}) {
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

// No builder gets gRPC's reflection plugin: a ServerBuilder copies every
// plugin factory registered with the process (something calling
// InitProtoReflectionServerBuilderPlugin would put reflection, without a
// token check, on every server, the health port's included), so each
// builder drops it. The gRPC port serves riskplan's own reflection instead
// (server/security/reflection_service.h).
class NoReflectionPlugin final : public grpc::ServerBuilderOption {
 public:
  void UpdateArguments(grpc::ChannelArguments* /*args*/) override {}
  void UpdatePlugins(std::vector<std::unique_ptr<grpc::ServerBuilderPlugin>>* plugins) override {
    std::erase_if(*plugins, [](const std::unique_ptr<grpc::ServerBuilderPlugin>& plugin) {
      return plugin->name() == "proto_server_reflection";
    });
  }
};

// The plaintext health port: a server of its own, with no Planner service
// and no reflection, so that nothing but health is ever served without TLS
// and tokens.
absl::StatusOr<std::unique_ptr<HealthPort>> StartHealthServer(const std::string& address) {
  grpc::ServerBuilder builder;
  builder.SetOption(std::make_unique<NoReflectionPlugin>());
  int port = 0;
  builder.AddListeningPort(address, grpc::InsecureServerCredentials(), &port);
  auto health = std::make_unique<HealthPort>();
  std::unique_ptr<grpc::ServerCompletionQueue> queue = builder.AddCompletionQueue();
  health->server = builder.BuildAndStart();
  health->queue = std::make_unique<PolledQueue>(std::move(queue));
  if (health->server == nullptr || port == 0) {
    return absl::UnavailableError(
        absl::StrFormat("cannot start: cannot listen on --health_listen=%s", address));
  }
  LogEvent("health_listening",
           absl::StrFormat("%s:%d", address.substr(0, address.rfind(':')), port));
  return health;
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

}  // namespace

PolledQueue::PolledQueue(std::unique_ptr<grpc::ServerCompletionQueue> queue)
    : queue_(std::move(queue)), thread_([this] {
        void* tag = nullptr;
        bool ok = false;
        while (queue_->Next(&tag, &ok)) {
        }
      }) {}

PolledQueue::~PolledQueue() {
  queue_->Shutdown();
  thread_.join();
}

sigset_t BlockStopSignals() {
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGTERM);
  sigaddset(&stop_signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  return stop_signals;
}

absl::StatusOr<LoadedMaps> LoadMaps(const ServerConfig& config) {
  const absl::Time load_start = absl::Now();
  absl::StatusOr<std::unique_ptr<MapRegistry>> registry =
      config.maps_dir.empty()
          ? MapRegistry::DemoCity(DemoCityOptions{.size_m = config.demo_city_size_m})
          : MapRegistry::LoadDirectory(config.maps_dir);
  if (!registry.ok()) return registry.status();
  absl::StatusOr<std::unique_ptr<RiskModelCache>> models = RiskModelCache::Create(
      **registry, config.model_cache_size, BuildLimits(config.options.limits));
  if (!models.ok()) return models.status();
  LogEvent("maps_loaded", absl::StrFormat("maps=[%s] bytes=%d seconds=%.2f",
                                          (*registry)->NameList(), (*registry)->MemoryBytes(),
                                          absl::ToDoubleSeconds(absl::Now() - load_start)));
  return LoadedMaps{*std::move(registry), *std::move(models)};
}

absl::StatusOr<std::unique_ptr<accel::RiskEngine>> MakeEngine(const ServerConfig& server_config) {
  const EngineConfig& config = server_config.engine;
  const accel::KernelPrecision cpu_kernel = config.cpu_kernel;
  const std::string& shims = config.fpga_shims;
  if (config.cpu_workers <= 0 && shims.empty() && cpu_kernel == accel::KernelPrecision::kExact) {
    return nullptr;
  }
  accel::RiskEngineOptions engine_options;
  engine_options.cpu_workers = config.cpu_workers;
  engine_options.caller_runs = config.caller_runs;
  engine_options.site_cache_bytes = config.site_cache_bytes;
  engine_options.kernel.precision = cpu_kernel;
  engine_options.kernel_weights_bytes = config.kernel_weights_bytes;
  engine_options.prepared_map_bytes = config.prepared_map_bytes;
  engine_options.blob_cache_bytes = config.blob_cache_bytes;
  for (absl::string_view s : absl::StrSplit(shims, ',', absl::SkipWhitespace())) {
    engine_options.fpga_shims.emplace_back(s);
  }
  if (config.shim_tls.enabled() || !config.shim_tls_server_name.empty()) {
    absl::StatusOr<std::shared_ptr<net::TlsContext>> tls =
        net::TlsContext::ForClient(config.shim_tls);
    if (!tls.ok()) return tls.status();
    engine_options.fpga.client.tls = *std::move(tls);
    engine_options.fpga.client.tls_server_name = config.shim_tls_server_name;
  } else if (!server_config.security.allow_plaintext) {
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
  LogEvent(
      "accel_engine",
      absl::StrFormat("cpu_workers=%d fpga_shims=[%s] fpga_tls=%s caller_runs=%d cpu_kernel=%s",
                      engine_options.cpu_workers, shims,
                      engine_options.fpga.client.tls != nullptr ? "on" : "off",
                      engine_options.caller_runs, accel::KernelPrecisionName(cpu_kernel)));
  return engine;
}

absl::Status StartMetrics(accel::RiskEngine* engine, ServerMetrics& metrics,
                          const std::string& address) {
  if (engine != nullptr) metrics.AddCollectable(std::make_shared<AccelMetrics>(engine));
  if (address.empty()) return absl::OkStatus();
  absl::StatusOr<std::string> bound = metrics.Expose(address);
  if (!bound.ok()) return bound.status();
  LogEvent("metrics_listening", *bound);
  return absl::OkStatus();
}

absl::StatusOr<Serving> BuildAndStart(const ServerConfig& config, PlannerService& service,
                                      ServerMetrics& metrics, const ServerSecurity& security) {
  const std::string& listen = config.listen;
  absl::StatusOr<std::unique_ptr<ConnectionAcceptor>> acceptor = ConnectionAcceptor::Listen(listen);
  if (!acceptor.ok()) {
    return absl::UnavailableError(absl::StrFormat("cannot start: cannot listen on --listen=%s: %s",
                                                  listen, acceptor.status().message()));
  }
  // Must be set before the builder is created: it installs itself as a
  // builder plugin.
  grpc::EnableDefaultHealthCheckService(true);
  grpc::ServerBuilder builder;
  builder.SetOption(std::make_unique<NoReflectionPlugin>());
  Serving serving;
  std::unique_ptr<grpc::experimental::ExternalConnectionAcceptor> connections =
      builder.experimental().AddExternalConnectionAcceptor(
          grpc::ServerBuilder::experimental_type::ExternalConnectionType::FROM_FD,
          security.credentials);
  builder.SetMaxReceiveMessageSize(config.max_request_bytes);
  // Responses are bounded by the request limits (samples, tree edges, layer
  // side); 64 MiB is the client library's receive limit too.
  builder.SetMaxSendMessageSize(64 << 20);
  if (const int64_t age_ms = config.max_connection_age_ms; age_ms > 0) {
    builder.AddChannelArgument(GRPC_ARG_MAX_CONNECTION_AGE_MS, static_cast<int>(age_ms));
  }
  builder.RegisterService(&service);
  // Reflection, a viewer method (server/security/auth.h), with the token
  // checked in its handler as in every Planner handler: on a plaintext port
  // too, where gRPC allows no token processor.
  serving.reflection = std::make_unique<ReflectionService>(
      std::vector<std::string>{"grpc.health.v1.Health",
                               "grpc.reflection.v1alpha.ServerReflection",
                               v1::Planner::service_full_name()},
      security.authorizer);
  builder.RegisterService(serving.reflection.get());
  serving.server = builder.BuildAndStart();
  if (serving.server == nullptr) {
    return absl::UnavailableError(
        absl::StrFormat("cannot start: gRPC did not start on --listen=%s", listen));
  }
  if (security.rotation != nullptr) metrics.AddCollectable(security.rotation->metrics());
  serving.acceptor = *std::move(acceptor);
  serving.acceptor->Start(std::move(connections), [&metrics] { metrics.RecordAcceptError(); });
  if (!config.health_listen.empty()) {
    absl::StatusOr<std::unique_ptr<HealthPort>> health = StartHealthServer(config.health_listen);
    if (!health.ok()) return health.status();
    serving.health = *std::move(health);
  }
  SetHealth(serving, true);
  serving.host = config.listen_host;
  serving.port = serving.acceptor->port();
  return serving;
}

void AnnounceServing(const Serving& serving, const ServiceOptions& options) {
  std::printf("riskplan-server listening on %s:%d\n", serving.host.c_str(), serving.port);
  std::fflush(stdout);
  LogEvent("serving",
           absl::StrFormat("address=%s:%d plan_threads=%d max_running_plans=%d eval_threads=%d",
                           serving.host, serving.port, options.plan_threads,
                           options.max_running_plans, options.eval_threads));
}

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
  if (serving.health != nullptr) serving.health->server->Shutdown(absl::ToChronoTime(absl::Now()));
  LogEvent("stopped",
           absl::StrFormat("seconds=%.3f", absl::ToDoubleSeconds(absl::Now() - drain_start)));
  // The drain is done; what is left is the orderly exit (destructors join
  // the workers, the maps are freed), which gets its own allowance rather
  // than the drain's: a drain that ended in milliseconds left the exit
  // seconds, and under a sanitizer on a loaded machine (its leak check
  // scans the heap at exit) that was not always enough.
  ExitWatchdog::Teardown(absl::Now() + kTeardownAllowance);
}

}  // namespace riskplan::server
