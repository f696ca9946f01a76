#include "web/gateway.h"

#include <httplib.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <zlib.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <memory>
#include <sstream>
#include <utility>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/time/clock.h"
#include "client/exports.h"
#include "geo/export/geojson.h"
#include "geo/export/kml.h"
#include "geo/export/qgc_plan.h"
#include "nlohmann/json.hpp"
#include "web/gateway_internal.h"
#include "web/proto_json.h"
#include "web/sse.h"

namespace riskplan::web {

using namespace gateway_internal;  // NOLINT: the route files' shared helpers

namespace {

using Json = nlohmann::json;

constexpr int kMaxLayerSideCells = 1024;
// The side the page asks its map layers at (map.js, fetchLayer).
constexpr int kPageLayerSideCells = 400;
// A warm-up call waits no longer: a SIGTERM waits for the one in flight.
constexpr absl::Duration kWarmCallTimeout = absl::Seconds(10);
constexpr v1::MapLayer kPageLayers[] = {v1::POPULATION_DENSITY, v1::SHELTER, v1::TERRAIN,
                                        v1::NO_FLY};

// Where the pre-routing handler moves a request's Accept-Encoding (below,
// Routes): cpp-httplib then compresses nothing itself.
constexpr char kAcceptEncodingSeen[] = "X-Riskplan-Accept-Encoding";
// Smaller answers are sent as they are: compressing them saves nothing.
constexpr size_t kMinGzipBytes = 1024;

bool AcceptsGzip(const httplib::Request& req) {
  return absl::StrContains(req.get_header_value(kAcceptEncodingSeen), "gzip");
}

// `text` gzipped at zlib's fastest level: a 2 MB layer in some 20 ms, to
// about a fifth of its size (JSON of numbers compresses well even so).
std::string Gzip(const std::string& text) {
  z_stream z{};
  // 15 + 16: a gzip header and trailer rather than zlib's.
  if (deflateInit2(&z, 1, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK) return "";
  std::string out(deflateBound(&z, text.size()), '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(text.data()));
  z.avail_in = static_cast<uInt>(text.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  const int result = deflate(&z, Z_FINISH);
  out.resize(z.total_out);
  deflateEnd(&z);
  return result == Z_STREAM_END ? out : "";
}

// A route that is one unary RPC: the body is the request's JSON form, the
// answer the response's.
template <typename RpcRequest, typename RpcResponse, typename Call>
void ForwardUnary(const httplib::Request& req, httplib::Response& res, Call call) {
  RpcRequest request;
  if (absl::Status s = FromJson(req.body, &request); !s.ok()) return SendGatewayError(res, s);
  RpcResponse response;
  const grpc::Status status = call(request, &response);
  if (!status.ok()) return SendServerError(res, status);
  SendJsonTo(req, res, ToJson(response));
}

// The file of an export in `format` (geojson, plan or kml; checked by the
// caller) and its content type.
absl::StatusOr<std::string> ExportText(const std::string& format,
                                       const geo::ExportTrajectory& trajectory,
                                       std::string* content_type) {
  if (format == "geojson") {
    *content_type = "application/geo+json";
    return geo::TrajectoryGeoJson(trajectory);
  }
  if (format == "plan") {
    *content_type = "application/json";
    return geo::QgcPlanJson(trajectory);
  }
  *content_type = "application/vnd.google-earth.kml+xml";
  return geo::TrajectoryKml(trajectory);
}

// "HOST:PORT", "[V6]:PORT".
absl::StatusOr<std::pair<std::string, int>> SplitHostPort(const std::string& address) {
  const size_t colon = address.rfind(':');
  int port = -1;
  if (colon == std::string::npos || colon == 0 ||
      !absl::SimpleAtoi(address.substr(colon + 1), &port) || port < 0 || port > 65535) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "--listen has value '%s'; it must be HOST:PORT, port in [0, 65535]", address));
  }
  std::string host = address.substr(0, colon);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') {
    host = host.substr(1, host.size() - 2);
  }
  return std::make_pair(host, port);
}

// A map's fingerprint: its name and a hash of its MapInfo (a map replaced
// on the server under the same name has another).
std::string Fingerprint(const v1::MapInfo& info) {
  return absl::StrCat(info.name(), "#", std::hash<std::string>{}(info.SerializeAsString()));
}


// Whether (lon, lat) lies inside the convex quadrilateral of `corners`
// (south-west, south-east, north-east, north-west), on or off its edges.
bool InsideCorners(const v1::GeoBounds& bounds, double lat, double lon) {
  if (bounds.corners_size() != 4) return true;  // nothing to check against
  int sign = 0;
  for (int k = 0; k < 4; ++k) {
    const v1::GeoPoint2& a = bounds.corners(k);
    const v1::GeoPoint2& b = bounds.corners((k + 1) % 4);
    const double cross = (b.lon_deg() - a.lon_deg()) * (lat - a.lat_deg()) -
                         (b.lat_deg() - a.lat_deg()) * (lon - a.lon_deg());
    const int s = cross > 0 ? 1 : (cross < 0 ? -1 : 0);
    if (s != 0) {
      if (sign != 0 && s != sign) return false;
      sign = s;
    }
  }
  return true;
}

// Start or goal of `request` against `map`'s area; `which` is "start" or
// "goal".
absl::Status CheckEndpoint(const v1::MapInfo& map, const char* which, const v1::Pose* local,
                           const v1::GeoPose* wgs84) {
  if (local != nullptr) {
    const double x0 = map.x0_m(), x1 = map.x0_m() + map.width_m();
    const double y0 = map.y0_m(), y1 = map.y0_m() + map.height_m();
    if (!(local->x() >= x0 && local->x() <= x1 && local->y() >= y0 && local->y() <= y1)) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "%s (x, y) = (%.1f, %.1f) m is outside map '%s' (x %.1f .. %.1f m, y %.1f .. %.1f m)",
          which, local->x(), local->y(), map.name(), x0, x1, y0, y1));
    }
  } else if (wgs84 != nullptr && map.has_bounds_wgs84()) {
    if (!std::isfinite(wgs84->lat_deg()) || !std::isfinite(wgs84->lon_deg()) ||
        !InsideCorners(map.bounds_wgs84(), wgs84->lat_deg(), wgs84->lon_deg())) {
      const v1::GeoBounds& b = map.bounds_wgs84();
      return absl::InvalidArgumentError(absl::StrFormat(
          "%s_wgs84 (lat, lon) = (%.6f, %.6f) deg is outside map '%s' (lat %.6f .. %.6f, lon "
          "%.6f .. %.6f deg)",
          which, wgs84->lat_deg(), wgs84->lon_deg(), map.name(), b.min_lat_deg(),
          b.max_lat_deg(), b.min_lon_deg(), b.max_lon_deg()));
    }
  }
  return absl::OkStatus();
}

// The page's files and the libraries' directories must exist.
bool IsDirectory(const std::string& path) {
  struct stat st;
  return stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

}  // namespace

namespace gateway_internal {

// What the page sees of a failed request: the code, the message exactly as
// its author wrote it, and who wrote it ("server" or "gateway").
void SendError(httplib::Response& res, int http_status, const std::string& code,
               const std::string& message, const char* source) {
  res.status = http_status;
  res.set_content(Json{{"code", code}, {"message", message}, {"source", source}}.dump(
                      -1, ' ', false, Json::error_handler_t::replace),
                  "application/json");
}

int HttpStatusOf(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::INVALID_ARGUMENT:
    case grpc::StatusCode::OUT_OF_RANGE:
      return 400;
    case grpc::StatusCode::UNAUTHENTICATED:
      return 401;
    case grpc::StatusCode::PERMISSION_DENIED:
      return 403;
    case grpc::StatusCode::NOT_FOUND:
      return 404;
    case grpc::StatusCode::FAILED_PRECONDITION:
      return 412;
    case grpc::StatusCode::RESOURCE_EXHAUSTED:
      return 429;
    case grpc::StatusCode::UNAVAILABLE:
      return 503;
    case grpc::StatusCode::DEADLINE_EXCEEDED:
      return 504;
    default:
      return 502;
  }
}

void SendServerError(httplib::Response& res, const grpc::Status& status) {
  SendError(res, HttpStatusOf(status.error_code()), client::StatusCodeName(status.error_code()),
            status.error_message(), "server");
}

int HttpStatusOf(const absl::Status& status) {
  switch (status.code()) {
    case absl::StatusCode::kInvalidArgument:
      return 400;
    case absl::StatusCode::kNotFound:
      return 404;
    case absl::StatusCode::kFailedPrecondition:
      return 412;
    case absl::StatusCode::kResourceExhausted:
      return 429;
    case absl::StatusCode::kUnavailable:
      return 503;
    default:
      return 500;
  }
}

void SendGatewayError(httplib::Response& res, const absl::Status& status) {
  SendError(res, HttpStatusOf(status), std::string(absl::StatusCodeToString(status.code())),
            std::string(status.message()), "gateway");
}

void SendJson(httplib::Response& res, std::string json, int http_status) {
  res.status = http_status;
  res.set_header("Cache-Control", "no-store");
  res.set_content(std::move(json), "application/json");
}

// The same, gzipped (`gzip`, or made here when empty) when the browser
// takes gzip and the answer is worth it.
void SendJsonTo(const httplib::Request& req, httplib::Response& res, std::string json,
                std::string gzip) {
  if (json.size() >= kMinGzipBytes && AcceptsGzip(req)) {
    if (gzip.empty()) gzip = Gzip(json);
    if (!gzip.empty()) {
      res.status = 200;
      res.set_header("Cache-Control", "no-store");
      res.set_header("Content-Encoding", "gzip");
      res.set_header("Vary", "Accept-Encoding");
      res.set_content(std::move(gzip), "application/json");
      return;
    }
  }
  SendJson(res, std::move(json));
}

const v1::MapInfo* FindMap(const v1::ListMapsResponse& maps, const std::string& name) {
  for (const v1::MapInfo& m : maps.maps()) {
    if (m.name() == name) return &m;
  }
  return nullptr;
}

absl::Status JsonMessageField(const nlohmann::json& root, const char* key,
                              google::protobuf::Message* message) {
  if (!root.contains(key)) return absl::OkStatus();
  if (!root[key].is_object()) {
    return absl::InvalidArgumentError(absl::StrFormat("'%s' must be a JSON object", key));
  }
  if (absl::Status s = FromJson(root[key].dump(), message); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrFormat("'%s': %s", key, s.message()));
  }
  return absl::OkStatus();
}

}  // namespace gateway_internal

absl::Status CheckGatewayOptions(const GatewayOptions& o) {
  if (auto hp = SplitHostPort(o.listen); !hp.ok()) return hp.status();
  if (o.server.address.empty()) return absl::InvalidArgumentError("--server must not be empty");
  if (o.max_viewers < 1 || o.max_viewers > 4096) {
    return absl::InvalidArgumentError(
        absl::StrFormat("--max_viewers has value %d; it must be in [1, 4096]", o.max_viewers));
  }
  if (o.flights.max_running < 0 || o.flights.max_running > 64) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "--max_flights has value %d; it must be in [0, 64] (0: no flights)",
        o.flights.max_running));
  }
  if (o.flights.max_zones < 1 || o.flights.max_zones > 64) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "--max_flight_zones has value %d; it must be in [1, 64] (the server's default bound)",
        o.flights.max_zones));
  }
  if (o.request_threads < 2 || o.request_threads > 1024) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "--request_threads has value %d; it must be in [2, 1024]", o.request_threads));
  }
  if (o.plans.max_running < 1 || o.plans.max_running > 256) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "--max_running_plans has value %d; it must be in [1, 256]", o.plans.max_running));
  }
  if (o.plans.max_kept < o.plans.max_running || o.plans.max_kept > 4096) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "--max_kept_plans has value %d; it must be in [--max_running_plans (%d), 4096]",
        o.plans.max_kept, o.plans.max_running));
  }
  if (o.plans.events.max_events < 1) {
    return absl::InvalidArgumentError("--max_events_per_plan must be at least 1");
  }
  if (o.heartbeat < absl::Milliseconds(10) || o.heartbeat > absl::Minutes(5)) {
    return absl::InvalidArgumentError("--heartbeat_ms must be in [10, 300000]");
  }
  for (const auto& [flag, dir] :
       {std::pair<const char*, const std::string*>{"assets_dir", &o.assets_dir},
        {"leaflet_dir", &o.leaflet_dir},
        {"chartjs_dir", &o.chartjs_dir}}) {
    if (!IsDirectory(*dir)) {
      return absl::InvalidArgumentError(
          absl::StrFormat("--%s has value '%s', which is not a directory", flag, *dir));
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<std::string> FindAssetsDir(const std::vector<std::string>& candidates) {
  for (const std::string& dir : candidates) {
    struct stat st;
    if (stat((dir + "/index.html").c_str(), &st) == 0 && S_ISREG(st.st_mode)) return dir;
  }
  return absl::NotFoundError(absl::StrCat("the page's files (index.html) are in none of ",
                                          absl::StrJoin(candidates, ", "),
                                          "; give their directory with --assets_dir"));
}

Gateway::Gateway(GatewayOptions options, std::shared_ptr<grpc::Channel> channel)
    : Gateway(std::move(options), std::move(channel), std::make_unique<httplib::Server>()) {}

Gateway::Gateway(GatewayOptions options, std::shared_ptr<grpc::Channel> channel,
                 std::unique_ptr<httplib::Server> http)
    : options_(std::move(options)),
      client_(std::move(channel)),
      plans_(&client_.stub(), options_.plans),
      flights_(options_.flights),
      http_(std::move(http)) {
  // One thread per connection for as long as it lives: event streams hold
  // theirs, so the pool is sized for every viewer plus the other requests.
  const size_t threads =
      static_cast<size_t>(options_.max_viewers) + static_cast<size_t>(options_.request_threads);
  http_->new_task_queue = [threads] { return new httplib::ThreadPool(threads); };
  http_->set_payload_max_length(options_.max_body_bytes);
  // cpp-httplib's default sets SO_REUSEPORT, with which a second gateway on
  // the same port would start silently and take half the connections;
  // SO_REUSEADDR only, and the listening socket is kept for Bind().
  http_->set_socket_options([this](int sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
    listen_socket_ = sock;
  });
  // An idle keep-alive connection holds a request thread; a browser keeps up
  // to six, so they are let go soon.
  http_->set_keep_alive_timeout(2);
  http_->set_exception_handler(
      [](const httplib::Request&, httplib::Response& res, std::exception_ptr ep) {
        std::string what = "unknown exception";
        try {
          std::rethrow_exception(ep);
        } catch (const std::exception& e) {
          what = e.what();
        } catch (...) {
        }
        SendError(res, 500, "INTERNAL", what, "gateway");
      });
  Routes();
}

Gateway::~Gateway() { Stop(); }

absl::StatusOr<int> Gateway::Bind() {
  auto hp = SplitHostPort(options_.listen);
  if (!hp.ok()) return hp.status();
  const auto& [host, port] = *hp;
  int bound = port;
  if (port == 0) {
    bound = http_->bind_to_any_port(host);
    if (bound <= 0) return absl::UnavailableError(absl::StrCat("cannot bind ", options_.listen));
  } else if (!http_->bind_to_port(host, port)) {
    return absl::UnavailableError(absl::StrCat("cannot bind ", options_.listen));
  }
  // cpp-httplib 0.11 listens with a backlog of 5: a page opening its event
  // stream and its calls, or a few viewers arriving together, would wait for
  // SYN retransmissions (1 s, then 3 s). Listening again sets the backlog.
  if (listen_socket_ >= 0) ::listen(listen_socket_, kListenBacklog);
  // Started here, on the thread that binds (before Serve's), so that Stop
  // finds it set.
  if (!warm_.joinable()) warm_ = std::thread([this] { WarmLayers(); });
  return bound;
}

void Gateway::Serve() { http_->listen_after_bind(); }

void Gateway::Stop() {
  if (stopping_.exchange(true)) {
    return;
  }
  // The warm-up checks stopping_ between layers (each a call of at most
  // kWarmCallTimeout).
  if (warm_.joinable()) warm_.join();
  // Ends the event streams (their waits wake up) and the plans, then the
  // HTTP server, which joins its threads once their streams returned.
  plans_.StopAll();
  flights_.StopAll();
  http_->stop();
}

void Gateway::Routes() {
  using httplib::Request;
  using httplib::Response;
  // cpp-httplib 0.11 answers a browser that takes Brotli (Chromium does)
  // with Brotli at its slowest level: 3 s for a 2 MB layer, every time. So
  // it is told of no encoding at all (the request's Accept-Encoding moves to
  // a header of ours) and the gateway compresses its JSON itself: gzip at
  // the fastest level, a map layer once (docs/web.md, "Speed").
  http_->set_pre_routing_handler([](const Request& req, Response&) {
    // The request is the server's own object, passed const; moving one
    // header is all that is changed.
    auto& headers = const_cast<Request&>(req).headers;
    const auto it = headers.find("Accept-Encoding");
    if (it != headers.end()) {
      std::string value = it->second;
      headers.erase("Accept-Encoding");
      headers.emplace(kAcceptEncodingSeen, std::move(value));
    }
    // No route reads form fields, and cpp-httplib refuses a form body over
    // 8 KiB with a bare 413 (curl's --data-binary sends a .plan as a form):
    // a body is read as the text it is, bounded by max_body_bytes only.
    const auto type = headers.find("Content-Type");
    if (type != headers.end() &&
        absl::StartsWith(type->second, "application/x-www-form-urlencoded")) {
      headers.erase(type);
      headers.emplace("Content-Type", "text/plain");
    }
    return httplib::Server::HandlerResponse::Unhandled;
  });
  // What cpp-httplib refuses itself (a body over the limit: 413; a file or
  // route that does not exist: 404) gets the {code, message} of every other
  // refusal rather than an empty body.
  http_->set_error_handler(httplib::Server::HandlerWithResponse(
      [this](const Request& req, Response& res) {
    if (!res.body.empty()) return httplib::Server::HandlerResponse::Unhandled;
    if (res.status == 413) {
      SendError(res, 413, "RESOURCE_EXHAUSTED",
                absl::StrFormat("the request body is larger than this gateway accepts (%d "
                                "bytes at most)",
                                options_.max_body_bytes),
                "gateway");
    } else if (res.status == 404) {
      SendError(res, 404, "NOT_FOUND",
                absl::StrFormat("no page, file or route %s %s on this gateway", req.method,
                                req.path),
                "gateway");
    } else {
      SendError(res, res.status, "UNKNOWN",
                absl::StrFormat("HTTP %d for %s %s", res.status, req.method, req.path),
                "gateway");
    }
    return httplib::Server::HandlerResponse::Handled;
  }));
  http_->set_mount_point("/", options_.assets_dir);
  http_->set_mount_point("/lib/leaflet", options_.leaflet_dir);
  http_->set_mount_point("/lib/chart.js", options_.chartjs_dir);

  // Each route is a method of its own below (docs/web.md lists them): named
  // handlers rather than lambdas here, so that each reads on its own.
  const auto route = [this](void (Gateway::*handler)(const Request&, Response&)) {
    return [this, handler](const Request& req, Response& res) { (this->*handler)(req, res); };
  };
  http_->Get("/api/status", route(&Gateway::GetStatus));
  http_->Get("/api/maps", route(&Gateway::GetMaps));
  http_->Get("/api/layer", route(&Gateway::GetLayer));
  http_->Post("/api/risk_layer", route(&Gateway::PostRiskLayer));
  http_->Post("/api/evaluate", route(&Gateway::PostEvaluate));
  http_->Post("/api/export", route(&Gateway::PostExport));
  http_->Post("/api/plans", route(&Gateway::PostPlan));
  http_->Get(R"(/api/plans/([0-9a-f-]+))", route(&Gateway::GetPlan));
  http_->Post(R"(/api/plans/([0-9a-f-]+)/cancel)", route(&Gateway::PostPlanCancel));
  http_->Get(R"(/api/plans/([0-9a-f-]+)/events)", route(&Gateway::GetPlanEvents));
  http_->Get("/favicon.ico", route(&Gateway::GetFavicon));
  http_->Post("/api/mission/parse", route(&Gateway::PostMissionParse));
  http_->Post("/api/mission/plans", route(&Gateway::PostMissionPlan));
  http_->Post("/api/mission/export", route(&Gateway::PostMissionExport));
  http_->Post("/api/flights", route(&Gateway::PostFlight));
  http_->Get(R"(/api/flights/([0-9a-f-]+))", route(&Gateway::GetFlight));
  http_->Get(R"(/api/flights/([0-9a-f-]+)/events)", route(&Gateway::GetFlightEvents));
  http_->Post(R"(/api/flights/([0-9a-f-]+)/inputs)", route(&Gateway::PostFlightInput));
  http_->Post(R"(/api/flights/([0-9a-f-]+)/end)", route(&Gateway::PostFlightEnd));
}

// Browsers ask for /favicon.ico whatever the page links; the page's own
// icon (favicon.svg, which the page links) answers it.
void Gateway::GetFavicon(const httplib::Request&, httplib::Response& res) {
  std::ifstream in(options_.assets_dir + "/favicon.svg", std::ios::binary);
  std::stringstream svg;
  svg << in.rdbuf();
  if (!in || svg.str().empty()) {
    return SendError(res, 404, "NOT_FOUND", "this gateway's page has no favicon.svg", "gateway");
  }
  res.set_header("Cache-Control", "max-age=86400");
  res.set_content(svg.str(), "image/svg+xml");
}

absl::StatusOr<std::shared_ptr<const v1::ListMapsResponse>> Gateway::Maps(bool refresh) {
  if (!refresh) {
    absl::MutexLock lock(&cache_mu_);
    if (maps_ != nullptr) return maps_;
  }
  auto maps = std::make_shared<v1::ListMapsResponse>();
  const grpc::Status status = client_.ListMaps(maps.get(), options_.rpc_timeout);
  if (!status.ok()) {
    return absl::Status(static_cast<absl::StatusCode>(status.error_code()),
                        status.error_message());
  }
  KeepMaps(maps);
  return maps;
}

void Gateway::KeepMaps(std::shared_ptr<const v1::ListMapsResponse> maps) {
  absl::MutexLock lock(&cache_mu_);
  map_fingerprints_.clear();
  for (const v1::MapInfo& m : maps->maps()) map_fingerprints_[m.name()] = Fingerprint(m);
  maps_ = std::move(maps);
}

std::shared_ptr<const Gateway::CachedLayer> Gateway::FindLayer(const std::string& key) {
  absl::MutexLock lock(&cache_mu_);
  for (auto it = layers_.begin(); it != layers_.end(); ++it) {
    if (it->first == key) {
      layers_.splice(layers_.begin(), layers_, it);
      return layers_.front().second;
    }
  }
  return nullptr;
}

void Gateway::KeepLayer(const std::string& key, std::shared_ptr<const CachedLayer> layer) {
  absl::MutexLock lock(&cache_mu_);
  for (auto it = layers_.begin(); it != layers_.end(); ++it) {
    if (it->first == key) {
      layers_.erase(it);
      break;
    }
  }
  layers_.emplace_front(key, std::move(layer));
  while (layers_.size() > kMaxCachedLayers) layers_.pop_back();
}

absl::Status Gateway::CheckPlan(const v1::PlanRequest& request) {
  const int64_t time_ms = request.budget().time_ms();
  if (time_ms < 0 || time_ms > options_.max_plan_time_ms) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "budget.time_ms has value %d; it must be in [0, %d] (0: no time limit; this gateway's "
        "--max_plan_time_ms)",
        time_ms, options_.max_plan_time_ms));
  }
  if (request.budget().iterations() < 0) {
    return absl::InvalidArgumentError(
        absl::StrFormat("budget.iterations has value %d; it must be >= 0 (0: no iteration limit)",
                        request.budget().iterations()));
  }
  if (request.start_frame_case() == v1::PlanRequest::START_FRAME_NOT_SET) {
    return absl::InvalidArgumentError("start (or start_wgs84) is required");
  }
  if (request.goal_frame_case() == v1::PlanRequest::GOAL_FRAME_NOT_SET) {
    return absl::InvalidArgumentError("goal (or goal_wgs84) is required");
  }
  absl::StatusOr<std::shared_ptr<const v1::ListMapsResponse>> maps = Maps(false);
  if (!maps.ok()) return absl::OkStatus();  // the server will say what is wrong
  const v1::MapInfo* map = FindMap(**maps, request.map());
  if (map == nullptr) {
    // A map the server loaded since the last look.
    maps = Maps(true);
    if (!maps.ok()) return absl::OkStatus();
    map = FindMap(**maps, request.map());
  }
  if (map == nullptr) {
    std::vector<std::string> names;
    for (const v1::MapInfo& m : (*maps)->maps()) names.push_back(m.name());
    return absl::NotFoundError(absl::StrFormat("map '%s' is not on the server (it has: %s)",
                                               request.map(), absl::StrJoin(names, ", ")));
  }
  if (absl::Status s = CheckEndpoint(*map, "start", request.has_start() ? &request.start() : nullptr,
                                     request.has_start_wgs84() ? &request.start_wgs84() : nullptr);
      !s.ok()) {
    return s;
  }
  return CheckEndpoint(*map, "goal", request.has_goal() ? &request.goal() : nullptr,
                       request.has_goal_wgs84() ? &request.goal_wgs84() : nullptr);
}

void Gateway::GetStatus(const httplib::Request&, httplib::Response& res) {
  SendJson(res, Json{{"server", options_.server.address},
                     {"viewers", viewers_.load()},
                     {"max_viewers", options_.max_viewers},
                     {"running_plans", plans_.running()},
                     {"flights", flights_.running()},
                     {"max_flights", options_.flights.max_running},
                     {"max_running_plans", options_.plans.max_running}}
                    .dump());
}

void Gateway::GetMaps(const httplib::Request& req, httplib::Response& res) {
  auto maps = std::make_shared<v1::ListMapsResponse>();
  const grpc::Status status = client_.ListMaps(maps.get(), options_.rpc_timeout);
  if (!status.ok()) return SendServerError(res, status);
  KeepMaps(maps);
  SendJsonTo(req, res, ToJson(*maps));
}

// GET /api/layer?map=M&layer=POPULATION_DENSITY|SHELTER|TERRAIN|NO_FLY&max_side_cells=N
void Gateway::GetLayer(const httplib::Request& req, httplib::Response& res) {
  v1::GetMapLayerRequest request;
  request.set_map(req.get_param_value("map"));
  v1::MapLayer layer;
  if (!v1::MapLayer_Parse(req.get_param_value("layer"), &layer)) {
    return SendError(res, 400, "INVALID_ARGUMENT",
                     absl::StrFormat("layer has value '%s'; it must be one of "
                                     "POPULATION_DENSITY, SHELTER, TERRAIN, NO_FLY",
                                     req.get_param_value("layer")),
                     "gateway");
  }
  request.set_layer(layer);
  if (req.has_param("max_side_cells")) {
    int side = 0;
    if (!absl::SimpleAtoi(req.get_param_value("max_side_cells"), &side)) {
      return SendError(res, 400, "INVALID_ARGUMENT", "max_side_cells must be an integer",
                       "gateway");
    }
    // The server allows 4096 (16 Mi cells); as JSON for a browser that is
    // some 200 MB on the gateway for one request.
    if (side > kMaxLayerSideCells) {
      return SendError(res, 400, "INVALID_ARGUMENT",
                       absl::StrFormat("max_side_cells has value %d; this gateway serves "
                                       "layers of at most %d cells a side",
                                       side, kMaxLayerSideCells),
                       "gateway");
    }
    request.set_max_side_cells(side);  // the server checks the rest of its range
  }
  // The layer of a map the gateway knows (by its fingerprint) is made once.
  const std::string key = LayerKey(request.map(), layer, request.max_side_cells());
  if (!key.empty()) {
    if (std::shared_ptr<const CachedLayer> cached = FindLayer(key)) {
      return SendJsonTo(req, res, cached->json, cached->gzip);
    }
  }
  absl::StatusOr<std::shared_ptr<const CachedLayer>> made =
      MakeLayer(request, key, options_.rpc_timeout);
  if (!made.ok()) {
    return SendServerError(res, grpc::Status(static_cast<grpc::StatusCode>(made.status().code()),
                                             std::string(made.status().message())));
  }
  SendJsonTo(req, res, (*made)->json, (*made)->gzip);
}

std::string Gateway::LayerKey(const std::string& map, v1::MapLayer layer, int max_side_cells) {
  absl::MutexLock lock(&cache_mu_);
  const auto it = map_fingerprints_.find(map);
  if (it == map_fingerprints_.end()) return "";
  return absl::StrCat(it->second, "|", v1::MapLayer_Name(layer), "|", max_side_cells);
}

absl::StatusOr<std::shared_ptr<const Gateway::CachedLayer>> Gateway::MakeLayer(
    const v1::GetMapLayerRequest& request, const std::string& key, absl::Duration timeout) {
  v1::GetMapLayerResponse response;
  const grpc::Status status = client_.GetMapLayer(request, &response, timeout);
  if (!status.ok()) {
    return absl::Status(static_cast<absl::StatusCode>(status.error_code()),
                        status.error_message());
  }
  auto made = std::make_shared<CachedLayer>();
  made->json = ToJson(response);
  made->gzip = Gzip(made->json);
  if (!key.empty()) KeepLayer(key, made);
  return made;
}

void Gateway::WarmLayers() {
  absl::StatusOr<std::shared_ptr<const v1::ListMapsResponse>> maps = Maps(true);
  if (!maps.ok()) return;  // the server is not up yet: the page's calls make them
  size_t made = 0;
  for (const v1::MapInfo& info : (*maps)->maps()) {
    for (const v1::MapLayer layer : kPageLayers) {
      // The cache holds kMaxCachedLayers: warming more would drop the first.
      if (stopping_.load() || made >= kMaxCachedLayers) return;
      const std::string key = LayerKey(info.name(), layer, kPageLayerSideCells);
      if (key.empty() || FindLayer(key) != nullptr) continue;
      v1::GetMapLayerRequest request;
      request.set_map(info.name());
      request.set_layer(layer);
      request.set_max_side_cells(kPageLayerSideCells);
      if (MakeLayer(request, key, kWarmCallTimeout).ok()) ++made;
    }
  }
}

void Gateway::PostRiskLayer(const httplib::Request& req, httplib::Response& res) {
  ForwardUnary<v1::GetRiskLayerRequest, v1::GetRiskLayerResponse>(
      req, res, [this](const auto& request, auto* response) {
        return client_.GetRiskLayer(request, response, options_.rpc_timeout);
      });
}

void Gateway::PostEvaluate(const httplib::Request& req, httplib::Response& res) {
  ForwardUnary<v1::EvaluateRiskRequest, v1::EvaluateRiskResponse>(
      req, res, [this](const auto& request, auto* response) {
        return client_.EvaluateRisk(request, response, options_.rpc_timeout);
      });
}

// POST /api/export?format=geojson|plan|kml, body: an EvaluateRiskRequest
// (the trajectory; path_spacing_m 0 means 25 m). The server samples the
// path in WGS84; the writers of geo/export make the file.
void Gateway::PostExport(const httplib::Request& req, httplib::Response& res) {
  const std::string format = req.get_param_value("format");
  if (format != "geojson" && format != "plan" && format != "kml") {
    return SendError(
        res, 400, "INVALID_ARGUMENT",
        absl::StrFormat("format has value '%s'; it must be geojson, plan or kml", format),
        "gateway");
  }
  v1::EvaluateRiskRequest request;
  if (absl::Status s = FromJson(req.body, &request); !s.ok()) return SendGatewayError(res, s);
  if (request.path_spacing_m() == 0) request.set_path_spacing_m(25.0);
  request.set_include_samples(false);
  v1::EvaluateRiskResponse response;
  const grpc::Status status = client_.EvaluateRisk(request, &response, options_.rpc_timeout);
  if (!status.ok()) return SendServerError(res, status);
  auto trajectory =
      client::ExportTrajectoryOf(response, request.map(), "riskplan-web", request.path_spacing_m());
  if (!trajectory.ok()) return SendGatewayError(res, trajectory.status());
  std::string content_type;
  absl::StatusOr<std::string> text = ExportText(format, *trajectory, &content_type);
  if (!text.ok()) return SendGatewayError(res, text.status());
  res.set_header("Content-Disposition",
                 absl::StrFormat("attachment; filename=\"riskplan-%s.%s\"", request.map(), format));
  res.set_content(std::move(*text), content_type);
}

// POST /api/plans, body: a PlanRequest. Starts the plan; its events are at
// /api/plans/ID/events. The server's refusal of the request (a start that
// is not admissible, say) arrives there as the "error" event.
void Gateway::PostPlan(const httplib::Request& req, httplib::Response& res) {
  v1::PlanRequest request;
  if (absl::Status s = FromJson(req.body, &request); !s.ok()) return SendGatewayError(res, s);
  // What the server would refuse at once is refused here, before a plan and
  // its event stream exist (docs/web.md).
  if (absl::Status s = CheckPlan(request); !s.ok()) return SendGatewayError(res, s);
  // A final tree can hold 50 000 edges: too much for an event kept in
  // memory and sent to every viewer.
  request.set_include_tree(false);
  auto session = plans_.Start(std::move(request));
  if (!session.ok()) return SendGatewayError(res, session.status());
  const std::string& id = (*session)->id();
  SendJson(res, Json{{"id", id}, {"events", absl::StrCat("/api/plans/", id, "/events")}}.dump(),
           201);
}

std::shared_ptr<PlanSession> Gateway::FindPlan(const httplib::Request& req,
                                               httplib::Response& res) {
  std::shared_ptr<PlanSession> session = plans_.Find(req.matches[1]);
  if (!session) {
    SendError(res, 404, "NOT_FOUND",
              absl::StrCat("no plan '", std::string(req.matches[1]), "' on this gateway"),
              "gateway");
  }
  return session;
}

void Gateway::GetPlan(const httplib::Request& req, httplib::Response& res) {
  std::shared_ptr<PlanSession> session = FindPlan(req, res);
  if (!session) return;
  const auto [first, last] = session->kept_range();
  SendJson(res, Json{{"id", session->id()},
                     {"state", PlanStateName(session->state())},
                     {"last_event_id", session->last_event_id()},
                     {"first_kept_event_id", first},
                     {"last_kept_event_id", last}}
                    .dump());
}

void Gateway::PostPlanCancel(const httplib::Request& req, httplib::Response& res) {
  std::shared_ptr<PlanSession> session = FindPlan(req, res);
  if (!session) return;
  SendJson(res, Json{{"cancelled", session->Cancel()}}.dump());
}

// The event stream of a plan (text/event-stream). A viewer that sends
// Last-Event-ID (or ?last_event_id=N) gets the events after N.
void Gateway::GetPlanEvents(const httplib::Request& req, httplib::Response& res) {
  std::shared_ptr<PlanSession> session = FindPlan(req, res);
  if (!session) return;
  // The log lives as long as the stream holds it, and its session with it.
  ServeEvents(std::shared_ptr<EventLog>(session, &session->events()), req, res);
}

void Gateway::ServeEvents(std::shared_ptr<EventLog> log, const httplib::Request& req,
                          httplib::Response& res) {
  std::string last = req.get_header_value("Last-Event-ID");
  if (last.empty()) last = req.get_param_value("last_event_id");
  const std::optional<uint64_t> after = ParseLastEventId(last);
  if (!after) {
    return SendError(res, 400, "INVALID_ARGUMENT",
                     absl::StrFormat("Last-Event-ID has value '%s'; it must be an event id, a "
                                     "decimal number",
                                     last),
                     "gateway");
  }
  // A browser reconnects on its own whenever a stream ends; 204 is how
  // the standard tells it that there is nothing more, ever.
  if (log->ended() && *after >= log->last_event_id()) {
    res.status = 204;
    return;
  }
  if (!AdmitViewer(res)) return;
  StreamEvents(std::move(log), *after, res);
}

bool Gateway::AdmitViewer(httplib::Response& res) {
  int open = viewers_.load();
  do {
    if (open >= options_.max_viewers) {
      res.set_header("Retry-After", "5");
      SendError(res, 503, "RESOURCE_EXHAUSTED",
                absl::StrFormat("this gateway holds at most %d event streams at once "
                                "(--max_viewers) and all are open; try again when a "
                                "viewer has closed",
                                options_.max_viewers),
                "gateway");
      return false;
    }
  } while (!viewers_.compare_exchange_weak(open, open + 1));
  return true;
}

void Gateway::StreamEvents(std::shared_ptr<EventLog> session, uint64_t after,
                           httplib::Response& res) {
  struct Viewer {
    std::shared_ptr<EventLog> session;
    uint64_t after = 0;
    bool started = false;
  };
  auto viewer = std::make_shared<Viewer>(Viewer{std::move(session), after});
  res.set_header("Cache-Control", "no-store");
  res.set_header("X-Accel-Buffering", "no");
  res.set_chunked_content_provider(
      "text/event-stream",
      [this, viewer](size_t /*offset*/, httplib::DataSink& sink) {
        if (!viewer->started) {
          viewer->started = true;
          const std::string retry = FormatSseRetry(options_.retry_ms);
          return sink.write(retry.data(), retry.size());
        }
        std::vector<PlanEvent> events;
        const bool end = viewer->session->WaitForEvents(viewer->after,
                                                        absl::Now() + options_.heartbeat, &events);
        if (stopping_.load()) {
          sink.done();
          return true;
        }
        std::string out;
        for (const PlanEvent& e : events) {
          out += FormatSseEvent(e.id, e.type, *e.data);
          viewer->after = e.id;
        }
        // Nothing new: a comment, so that a viewer who left is found out.
        if (out.empty() && !end) out = FormatSseComment("waiting");
        if (!out.empty() && !sink.write(out.data(), out.size())) return false;
        if (end) sink.done();
        return true;
      },
      // The viewer admitted by AdmitViewer leaves when its stream ends.
      [this](bool /*success*/) { viewers_.fetch_sub(1); });
}

}  // namespace riskplan::web
