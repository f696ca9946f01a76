// Gateway: riskplan-web's HTTP server. A client of riskplan-server over gRPC
// (through the public API only) and an HTTP/1.1 server for browsers: the
// page and its libraries, JSON forms of the RPCs, and plans streamed as
// Server-Sent Events (docs/web.md lists every route).
//
// Threads: cpp-httplib serves each connection on a thread of a fixed pool
// for as long as the connection lives, so an open event stream holds a
// thread. The pool has max_viewers + request_threads threads and at most
// max_viewers event streams are open at once: a viewer past that is refused
// at once (503, naming the limit), and the request threads stay free for the
// page's other requests. Each running plan reads its gRPC stream on a thread
// of its own (PlanSession), at most max_running_plans.
#ifndef RISKPLAN_WEB_GATEWAY_H_
#define RISKPLAN_WEB_GATEWAY_H_

#include <atomic>
#include <cstdint>
#include <list>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "client/client.h"
#include "web/event_log.h"
#include "web/flight_session.h"
#include "web/plan_session.h"
#include "web/server_link.h"

namespace httplib {
class Server;
struct Request;
struct Response;
}  // namespace httplib

namespace riskplan::web {

struct GatewayOptions {
  std::string listen = "127.0.0.1:8080";  // HOST:PORT; port 0 picks a free one
  ServerLinkOptions server;               // the gRPC link to riskplan-server
  // Directories served as /, /lib/leaflet/ and /lib/chart.js/.
  std::string assets_dir;
  std::string leaflet_dir = "/usr/share/javascript/leaflet";
  std::string chartjs_dir = "/usr/share/javascript/chart.js";
  int max_viewers = 64;                         // event streams open at once
  int request_threads = 16;                     // threads for everything else
  absl::Duration heartbeat = absl::Seconds(5);  // comment on an idle event stream
  int retry_ms = 1000;                          // the browsers' reconnection delay
  PlanRegistryLimits plans;
  FlightGatewayLimits flights;  // --max_flights, --max_flight_zones
  size_t max_body_bytes = size_t{4} << 20;
  absl::Duration rpc_timeout = absl::Seconds(60);  // unary calls' deadline
  // A plan's time budget above this is refused with 400 before the plan
  // starts (the server's --max_plan_time_ms, whose default it is).
  int64_t max_plan_time_ms = 600000;
};

// InvalidArgument naming the option when `options` cannot work.
absl::Status CheckGatewayOptions(const GatewayOptions& options);

// The page's directory when --assets_dir is not given: the first of
// `candidates` that holds index.html (riskplan-web tries the source tree's
// web/static, then share/riskplan/web beside its own bin/, then the install
// prefix's); NotFound naming every candidate when none does.
absl::StatusOr<std::string> FindAssetsDir(const std::vector<std::string>& candidates);

class Gateway {
 public:
  // A gateway to the server on `channel` (MakeServerChannel(options.server)).
  Gateway(GatewayOptions options, std::shared_ptr<grpc::Channel> channel);
  // The same, serving its routes on `http` (a subclass of httplib::Server:
  // the fuzz target of fuzz/web_gateway_fuzz.cc feeds it requests from
  // memory instead of a socket).
  Gateway(GatewayOptions options, std::shared_ptr<grpc::Channel> channel,
          std::unique_ptr<httplib::Server> http);
  ~Gateway();  // Stop()
  Gateway(const Gateway&) = delete;
  Gateway& operator=(const Gateway&) = delete;

  // Binds options.listen; the bound port (the real one for port 0).
  // Unavailable when the address cannot be bound.
  absl::StatusOr<int> Bind();
  // Serves until Stop(). REQUIRES: Bind() succeeded.
  void Serve();
  // Stops serving: running plans are cancelled, event streams end, Serve
  // returns. Thread-safe; idempotent.
  void Stop();

  int open_viewers() const { return viewers_.load(); }

 private:
  void Routes();
  // The routes' handlers, one a route (docs/web.md lists the routes).
  void GetStatus(const httplib::Request& req, httplib::Response& res);
  void GetMaps(const httplib::Request& req, httplib::Response& res);
  void GetLayer(const httplib::Request& req, httplib::Response& res);
  void PostRiskLayer(const httplib::Request& req, httplib::Response& res);
  void PostEvaluate(const httplib::Request& req, httplib::Response& res);
  void PostExport(const httplib::Request& req, httplib::Response& res);
  void PostPlan(const httplib::Request& req, httplib::Response& res);
  void GetPlan(const httplib::Request& req, httplib::Response& res);
  void PostPlanCancel(const httplib::Request& req, httplib::Response& res);
  void GetPlanEvents(const httplib::Request& req, httplib::Response& res);
  void GetFavicon(const httplib::Request& req, httplib::Response& res);
  // QGroundControl missions (docs/web.md, "Missions"): a .plan read for the
  // page, planned leg by leg, and written back with its route.
  void PostMissionParse(const httplib::Request& req, httplib::Response& res);
  void PostMissionPlan(const httplib::Request& req, httplib::Response& res);
  void PostMissionExport(const httplib::Request& req, httplib::Response& res);
  // Flights (docs/web.md, "Flight"): a Fly session with a simulated aircraft.
  void PostFlight(const httplib::Request& req, httplib::Response& res);
  void GetFlight(const httplib::Request& req, httplib::Response& res);
  void GetFlightEvents(const httplib::Request& req, httplib::Response& res);
  void PostFlightInput(const httplib::Request& req, httplib::Response& res);
  void PostFlightEnd(const httplib::Request& req, httplib::Response& res);
  std::shared_ptr<FlightSession> FindFlight(const httplib::Request& req, httplib::Response& res);

  // The server's maps (ListMaps), kept from the last call: each map's
  // fingerprint (its MapInfo's bytes) keys the layer cache, and its bounds
  // check a plan's start and goal. `refresh` calls ListMaps again.
  absl::StatusOr<std::shared_ptr<const v1::ListMapsResponse>> Maps(bool refresh);
  void KeepMaps(std::shared_ptr<const v1::ListMapsResponse> maps);
  // What the gateway checks of a plan before it starts one (docs/web.md,
  // "Refused before the plan starts"): InvalidArgument or NotFound naming
  // the field.
  absl::Status CheckPlan(const v1::PlanRequest& request);
  // FailedPrecondition when the map `name` has no geo-reference (a mission
  // is in WGS84); an unknown map is CheckPlan's to name.
  absl::Status CheckMissionMap(const std::string& name);

  // A map layer as JSON and gzip (level 1), made once per map, layer and
  // side and kept (kMaxCachedLayers, the least recently used dropped).
  struct CachedLayer {
    std::string json;
    std::string gzip;
  };
  std::shared_ptr<const CachedLayer> FindLayer(const std::string& key);
  // The cache key of a layer of `map` (by its fingerprint), or "" when the
  // gateway has not listed that map yet.
  std::string LayerKey(const std::string& map, v1::MapLayer layer, int max_side_cells);
  // GetMapLayer, made into JSON and gzip, kept under `key` (when not "").
  absl::StatusOr<std::shared_ptr<const CachedLayer>> MakeLayer(
      const v1::GetMapLayerRequest& request, const std::string& key, absl::Duration timeout);
  // At start (Bind), every map's four layers at the side the page asks
  // for, made before the first page asks: its first map is then drawn from
  // the cache. Stops early when the gateway stops.
  void WarmLayers();
  void KeepLayer(const std::string& key, std::shared_ptr<const CachedLayer> layer);
  static constexpr size_t kMaxCachedLayers = 64;
  // The plan a /api/plans/ID/... route names; null, with the 404 sent, when
  // this gateway has none of that id.
  std::shared_ptr<PlanSession> FindPlan(const httplib::Request& req, httplib::Response& res);
  // Counts one more open event stream; false, with the 503 sent, when
  // max_viewers are open already.
  bool AdmitViewer(httplib::Response& res);
  // A session's event stream: Last-Event-ID (or ?last_event_id=) read, 204
  // when nothing more will come, the viewer admitted, then StreamEvents.
  void ServeEvents(std::shared_ptr<EventLog> log, const httplib::Request& req,
                   httplib::Response& res);
  // Streams `log`'s events after `after` as Server-Sent Events.
  void StreamEvents(std::shared_ptr<EventLog> log, uint64_t after, httplib::Response& res);

  const GatewayOptions options_;
  client::RiskplanClient client_;
  PlanRegistry plans_;
  FlightRegistry flights_;
  std::unique_ptr<httplib::Server> http_;
  // The listening socket (set by cpp-httplib's socket-options callback).
  int listen_socket_ = -1;
  static constexpr int kListenBacklog = 1024;
  std::atomic<int> viewers_{0};
  std::atomic<bool> stopping_{false};
  std::thread warm_;  // WarmLayers, joined by Stop

  absl::Mutex cache_mu_;
  std::shared_ptr<const v1::ListMapsResponse> maps_ ABSL_GUARDED_BY(cache_mu_);
  std::map<std::string, std::string> map_fingerprints_ ABSL_GUARDED_BY(cache_mu_);
  std::list<std::pair<std::string, std::shared_ptr<const CachedLayer>>> layers_
      ABSL_GUARDED_BY(cache_mu_);  // most recently used first
};

}  // namespace riskplan::web

#endif  // RISKPLAN_WEB_GATEWAY_H_
