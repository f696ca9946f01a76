// riskplan-web: the gateway between browsers and riskplan-server. Serves the
// page (Leaflet and Chart.js from Debian's packages, nothing from the
// internet), the API's calls as JSON, and plans as Server-Sent Events.
#include <signal.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "client/connection_flags.h"
#include "cmdline/help.h"
#include "web/gateway.h"

ABSL_FLAG(std::string, listen, "127.0.0.1:8080",
          "HTTP address for browsers, HOST:PORT; port 0 picks a free port, and "
          "'riskplan-web listening on HOST:PORT' on stdout gives the real one");
ABSL_FLAG(std::string, server, "127.0.0.1:50051",
          "riskplan-server's gRPC address: HOST:PORT, a list HOST:PORT,HOST:PORT,... of "
          "replicas, or a gRPC URI such as dns:///NAME:PORT (round-robin over every address)");
ABSL_FLAG(std::string, assets_dir, "",
          "Directory of the page's own files (empty: web/static of the source tree it was "
          "built from, else the installed share/riskplan/web)");
ABSL_FLAG(std::string, leaflet_dir, "/usr/share/javascript/leaflet",
          "Directory of Leaflet (Debian's libjs-leaflet)");
ABSL_FLAG(std::string, chartjs_dir, "/usr/share/javascript/chart.js",
          "Directory of Chart.js (Debian's libjs-chart.js)");
ABSL_FLAG(int, max_viewers, 64,
          "Event streams open at once (each holds an HTTP thread); more are refused with 503");
ABSL_FLAG(int, request_threads, 16, "HTTP threads for everything but event streams");
ABSL_FLAG(int, max_running_plans, 4, "Plans this gateway runs at once; more are refused with 429");
ABSL_FLAG(int, max_kept_plans, 32,
          "Plans whose events are kept for viewers (ended ones are dropped oldest first)");
ABSL_FLAG(int, max_events_per_plan, 2000,
          "Events kept per plan (the oldest improvements are dropped first)");
ABSL_FLAG(int, heartbeat_ms, 5000,
          "Comment sent on an idle event stream, which also finds viewers that left");
ABSL_FLAG(int, rpc_timeout_ms, 60000, "Deadline of the unary calls to the server");
ABSL_FLAG(int, max_flights, 2,
          "Flights (Fly sessions with a simulated aircraft) this gateway flies at once; more are "
          "refused with 429");
ABSL_FLAG(int, max_flight_zones, 16,
          "Zones the page may hold on one flight at once (the server's --max_flight_zones bounds "
          "them too)");
ABSL_FLAG(int64_t, max_plan_time_ms, 600000,
          "A plan whose time budget is above this is refused (400) before it starts: the "
          "server's --max_plan_time_ms");

namespace {

// Where the page's files may be, in order: the source tree this program was
// built from, then where `cmake --install` puts them: share/riskplan/web
// beside the program's bin/ (wherever the installed tree was moved), then
// the configured install prefix.
std::vector<std::string> AssetsDirCandidates() {
  std::vector<std::string> dirs = {RISKPLAN_WEB_ASSETS_DIR};
  std::error_code error;
  const std::filesystem::path program = std::filesystem::read_symlink("/proc/self/exe", error);
  if (!error) {
    dirs.push_back((program.parent_path() / RISKPLAN_WEB_INSTALLED_ASSETS_FROM_BIN)
                       .lexically_normal()
                       .string());
  }
  dirs.push_back(RISKPLAN_WEB_INSTALLED_ASSETS_DIR);
  return dirs;
}

int Run() {
  riskplan::web::GatewayOptions options;
  options.listen = absl::GetFlag(FLAGS_listen);
  options.server.address = absl::GetFlag(FLAGS_server);
  options.server.connection = riskplan::client::ConnectionOptionsFromFlags();
  options.assets_dir = absl::GetFlag(FLAGS_assets_dir);
  if (options.assets_dir.empty()) {
    absl::StatusOr<std::string> found = riskplan::web::FindAssetsDir(AssetsDirCandidates());
    if (!found.ok()) {
      std::fprintf(stderr, "riskplan-web: %s\n", std::string(found.status().message()).c_str());
      return 2;
    }
    options.assets_dir = *std::move(found);
  }
  options.leaflet_dir = absl::GetFlag(FLAGS_leaflet_dir);
  options.chartjs_dir = absl::GetFlag(FLAGS_chartjs_dir);
  options.max_viewers = absl::GetFlag(FLAGS_max_viewers);
  options.request_threads = absl::GetFlag(FLAGS_request_threads);
  options.plans.max_running = absl::GetFlag(FLAGS_max_running_plans);
  options.plans.max_kept = absl::GetFlag(FLAGS_max_kept_plans);
  const int max_events = absl::GetFlag(FLAGS_max_events_per_plan);
  options.plans.events.max_events = max_events < 1 ? 0 : static_cast<size_t>(max_events);
  options.flights.max_running = absl::GetFlag(FLAGS_max_flights);
  options.flights.max_zones = absl::GetFlag(FLAGS_max_flight_zones);
  options.flights.events = options.plans.events;
  options.heartbeat = absl::Milliseconds(absl::GetFlag(FLAGS_heartbeat_ms));
  options.rpc_timeout = absl::Milliseconds(absl::GetFlag(FLAGS_rpc_timeout_ms));
  options.max_plan_time_ms = absl::GetFlag(FLAGS_max_plan_time_ms);
  if (options.max_plan_time_ms < 1) {
    std::fprintf(stderr, "riskplan-web: --max_plan_time_ms must be at least 1\n");
    return 2;
  }
  if (absl::GetFlag(FLAGS_rpc_timeout_ms) < 1) {
    std::fprintf(stderr, "riskplan-web: --rpc_timeout_ms must be at least 1\n");
    return 2;
  }
  if (absl::Status s = riskplan::web::CheckGatewayOptions(options); !s.ok()) {
    std::fprintf(stderr, "riskplan-web: %s\n", std::string(s.message()).c_str());
    return 2;
  }

  // Only the main thread's sigwait sees SIGTERM and SIGINT (the mask is set
  // before any thread starts). A viewer that closes its connection makes the
  // next write fail with EPIPE, never SIGPIPE.
  sigset_t stop;
  sigemptyset(&stop);
  sigaddset(&stop, SIGTERM);
  sigaddset(&stop, SIGINT);
  pthread_sigmask(SIG_BLOCK, &stop, nullptr);
  signal(SIGPIPE, SIG_IGN);

  absl::StatusOr<std::shared_ptr<grpc::Channel>> channel =
      riskplan::web::MakeServerChannel(options.server);
  if (!channel.ok()) {
    std::fprintf(stderr, "riskplan-web: %s\n", std::string(channel.status().message()).c_str());
    return 2;
  }
  riskplan::web::Gateway gateway(options, *std::move(channel));
  absl::StatusOr<int> port = gateway.Bind();
  if (!port.ok()) {
    std::fprintf(stderr, "riskplan-web: %s\n", std::string(port.status().message()).c_str());
    return 1;
  }
  std::thread serving([&gateway] { gateway.Serve(); });
  const std::string host = options.listen.substr(0, options.listen.rfind(':'));
  std::printf("riskplan-web listening on %s:%d\n", host.c_str(), *port);
  std::fflush(stdout);
  std::fprintf(stderr, "riskplan-web: serving the page from %s for riskplan-server at %s\n",
               options.assets_dir.c_str(), options.server.address.c_str());

  int signal_number = 0;
  sigwait(&stop, &signal_number);
  gateway.Stop();
  serving.join();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  riskplan::cmdline::ProgramHelp help;
  help.program = "riskplan-web";
  help.usage =
      "the web view of riskplan: a gRPC client of riskplan-server and an HTTP server for "
      "browsers, with a page that shows the maps and the risk layer, plans live (every "
      "improvement as the server streams it), evaluates drawn polylines, downloads "
      "trajectories (GeoJSON, QGroundControl .plan, KML), plans uploaded QGroundControl "
      "missions leg by leg and flies plans in an in-flight session with a simulated "
      "aircraft and zones placed by clicks.\n"
      "\n"
      "  riskplan-web --listen=127.0.0.1:8080 --server=127.0.0.1:50051\n";
  help.footer =
      "Prints 'riskplan-web listening on HOST:PORT' on stdout once it serves; SIGTERM or "
      "SIGINT cancels the running plans, ends the event streams and exits 0. docs/web.md "
      "lists the routes.";
  riskplan::cmdline::ParseCommandLine(argc, argv, help);
  return Run();
}
