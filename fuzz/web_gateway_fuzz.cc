// Fuzz target: riskplan-web's handling of what a browser (or anyone who can
// reach its port) sends: raw HTTP/1.1 requests through cpp-httplib's request
// parser into the gateway's routes (web/gateway.cc): query parameters, JSON
// bodies into API messages (web/proto_json.cc), plan ids in paths,
// Last-Event-ID, the event streams' SSE framing, and the gRPC calls the
// routes make, which go to a real PlannerService in this process (through an
// in-process channel: no sockets) serving a 1 km demo-city under small
// limits, so that plans and evaluations run for real and briefly.
//
// Input: up to 8 HTTP requests separated by a line "=====" (each request is
// served as one connection). In a request the text "@ID@" is replaced by the
// id of the last plan a request of the same input started, so that the plan
// routes (status, cancel, events) are reached with a real id.
//
// Properties:
//   - every answer is a well-formed HTTP response: status in [200, 599];
//   - no 500 (the gateway's exception handler, or an absl status the gateway
//     does not map), and no 502 (a gRPC code the gateway does not map): the
//     server here is always up;
//   - an answer of type application/json is JSON, and an error's JSON has a
//     code, a message that is not empty, and its source ("gateway" or
//     "server");
//   - an event stream is SSE: every line is empty, a comment or one of the
//     fields retry, id, event, data; ids strictly increase; every event has a
//     type and its data; a stream ends with exactly one terminal event
//     ("final" or "error") unless it resumed after the end;
//   - the gateway's open-viewer count is back to 0 after every request.
// cpp-httplib is Debian's compiled library, not instrumented: coverage
// guides the fuzzer through the gateway's code, and ASan checks every byte
// the gateway touches, but not cpp-httplib's own parsing (docs/reliability.md).
#include <fcntl.h>
#include <httplib.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "absl/strings/str_split.h"
#include "absl/time/time.h"
#include "fuzz/fuzz_server.h"
#include "fuzz/fuzz_support.h"
#include "google/protobuf/stubs/logging.h"
#include "grpcpp/grpcpp.h"
#include "nlohmann/json.hpp"
#include "server/models/map_registry.h"
#include "server/observability/metrics.h"
#include "server/models/model_cache.h"
#include "server/planner_service.h"
#include "server/observability/rpc_log.h"
#include "web/gateway.h"

namespace riskplan::fuzz {
namespace {

using Json = nlohmann::json;
using namespace riskplan::server;

constexpr size_t kMaxRequests = 8;
constexpr absl::string_view kSeparator = "\n=====\n";

// A connection from memory: reads the request's bytes, keeps what the
// gateway writes.
class MemoryStream final : public httplib::Stream {
 public:
  explicit MemoryStream(absl::string_view in) : in_(in) {}
  bool is_readable() const override { return true; }
  bool is_writable() const override { return true; }
  ssize_t read(char* ptr, size_t size) override {
    const size_t n = std::min(size, in_.size() - pos_);
    std::memcpy(ptr, in_.data() + pos_, n);
    pos_ += n;
    return static_cast<ssize_t>(n);
  }
  ssize_t write(const char* ptr, size_t size) override {
    out_.append(ptr, size);
    return static_cast<ssize_t>(size);
  }
  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    ip = "127.0.0.1";
    port = 40000;
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    ip = "127.0.0.1";
    port = 8080;
  }
  socket_t socket() const override { return -1; }
  const std::string& out() const { return out_; }

 private:
  absl::string_view in_;
  size_t pos_ = 0;
  std::string out_;
};

// httplib::Server with its request processing reachable. cpp-httplib writes
// a chunked answer (an event stream) only while its listening socket is set
// (it takes an unset one for a server shutting down, and cuts the answer
// short): a descriptor of /dev/null stands in for it, never listened on.
class MemoryServer final : public httplib::Server {
 public:
  MemoryServer() {
    const int fd = open("/dev/null", O_RDONLY | O_CLOEXEC);
    if (fd < 0) Fail("cannot open /dev/null");
    svr_sock_ = fd;
  }
  ~MemoryServer() override { close(svr_sock_.exchange(INVALID_SOCKET)); }
  void Serve(httplib::Stream& stream) {
    bool closed = false;
    process_request(stream, /*close_connection=*/true, closed, nullptr);
  }
};

// The server behind the gateway, built once for the whole run.
struct Backend {
  std::unique_ptr<MapRegistry> maps;
  std::unique_ptr<RiskModelCache> models;
  std::unique_ptr<ServerMetrics> metrics;
  std::unique_ptr<PlannerService> service;
  std::unique_ptr<grpc::Server> server;
  std::shared_ptr<grpc::Channel> channel;

  Backend() {
    google::protobuf::SetLogHandler(nullptr);
    SetRpcLogEnabled(false);
    maps = FuzzMaps();
    ServiceOptions options;
    options.limits = FuzzLimits();
    absl::StatusOr<std::unique_ptr<RiskModelCache>> cache =
        RiskModelCache::Create(*maps, /*max_overridden=*/4, BuildLimits(options.limits));
    if (!cache.ok()) Fail(cache.status().ToString());
    models = *std::move(cache);
    metrics = std::make_unique<ServerMetrics>();
    service = std::make_unique<PlannerService>(*maps, *models, *metrics, options);
    grpc::ServerBuilder builder;
    builder.RegisterService(service.get());
    server = builder.BuildAndStart();
    if (server == nullptr) Fail("the in-process server did not start");
    channel = server->InProcessChannel(grpc::ChannelArguments());
  }
};

web::GatewayOptions FuzzGatewayOptions() {
  web::GatewayOptions options;
  options.server.address = "in-process";
  options.assets_dir = RISKPLAN_WEB_ASSETS_DIR;
  options.max_viewers = 2;
  options.heartbeat = absl::Milliseconds(10);
  options.plans.max_running = 2;
  options.plans.max_kept = 4;
  options.plans.events.max_events = 64;
  options.plans.events.max_bytes = size_t{1} << 20;
  options.flights.max_running = 1;  // a flight read from its start runs to its end
  options.max_body_bytes = size_t{64} << 10;
  options.rpc_timeout = absl::Seconds(20);
  return options;
}

struct Response {
  int status = 0;
  std::string content_type;
  std::string body;  // chunked bodies joined
};

// Splits what the gateway wrote into status, Content-Type and body (joining
// a chunked body); any framing that is not HTTP/1.1 fails.
// A broken property of the answer `out`: says which, with the answer (its
// first 4 KB), so that a crash's log shows what the gateway wrote.
[[noreturn]] void Broken(absl::string_view out, absl::string_view what) {
  Fail(absl::StrCat(what, "; the answer:\n", out.substr(0, 4096)));
}

Response ParseResponse(absl::string_view out) {
  Response r;
  const size_t head_end = out.find("\r\n\r\n");
  if (head_end == absl::string_view::npos) Broken(out, "an answer without a complete header");
  std::vector<absl::string_view> lines = absl::StrSplit(out.substr(0, head_end), "\r\n");
  if (lines.empty() || !absl::StartsWith(lines[0], "HTTP/1.1 ") || lines[0].size() < 12 ||
      !absl::SimpleAtoi(lines[0].substr(9, 3), &r.status)) {
    Broken(out, "an answer whose status line is not HTTP/1.1");
  }
  bool chunked = false;
  for (size_t i = 1; i < lines.size(); ++i) {
    const size_t colon = lines[i].find(':');
    if (colon == absl::string_view::npos) Broken(out, "a header line without a colon");
    const absl::string_view name = lines[i].substr(0, colon);
    absl::string_view value = absl::StripLeadingAsciiWhitespace(lines[i].substr(colon + 1));
    if (absl::EqualsIgnoreCase(name, "Content-Type")) r.content_type = std::string(value);
    if (absl::EqualsIgnoreCase(name, "Transfer-Encoding") && value == "chunked") chunked = true;
  }
  absl::string_view rest = out.substr(head_end + 4);
  if (!chunked) {
    r.body = std::string(rest);
    return r;
  }
  while (true) {
    const size_t eol = rest.find("\r\n");
    if (eol == absl::string_view::npos) Broken(out, "a chunked body cut short");
    size_t n = 0;
    if (!absl::SimpleHexAtoi(rest.substr(0, eol), &n)) Broken(out, "a chunk size that is not hex");
    rest.remove_prefix(eol + 2);
    if (n == 0) break;
    if (rest.size() < n + 2 || rest.substr(n, 2) != "\r\n") Broken(out, "a chunk cut short");
    absl::StrAppend(&r.body, rest.substr(0, n));
    rest.remove_prefix(n + 2);
  }
  return r;
}

void CheckJson(const Response& r) {
  Json json = Json::parse(r.body, nullptr, /*allow_exceptions=*/false);
  if (json.is_discarded()) Fail("an application/json answer that is not JSON");
  if (r.status < 400) return;
  if (!json.is_object() || !json.contains("code") || !json.contains("message") ||
      !json["message"].is_string() || json["message"].get<std::string>().empty() ||
      !json.contains("source")) {
    Fail("an error answer without its code, message and source");
  }
  const std::string source = json["source"].is_string() ? json["source"].get<std::string>() : "";
  if (source != "gateway" && source != "server") Fail("an error from an unknown source");
}

// The SSE framing of an event stream (the WHATWG HTML standard's
// text/event-stream), as a browser's EventSource reads it; the number of
// terminal events ("final", "cancelled", "failed"; a flight's "ended") it held.
int CheckEventStream(const std::string& body) {
  uint64_t last_id = 0;
  bool any_id = false;
  bool have_id = false, have_type = false;
  int data_lines = 0;
  int terminal = 0;
  std::string type, data;
  for (absl::string_view line : absl::StrSplit(body, '\n')) {
    if (line.empty()) {  // the end of an event: the browser dispatches it
      if (have_id || have_type || data_lines > 0) {
        if (!have_id || !have_type || data_lines != 1) {
          Fail("an event without its id and type, or not one data line");
        }
        Json json = Json::parse(data, nullptr, /*allow_exceptions=*/false);
        if (!json.is_object()) Fail("an event whose data is not a JSON object");
        if (type == "final" || type == "cancelled" || type == "failed" || type == "ended") {
          ++terminal;
        }
        if (type == "failed") {
          const std::string code = json.value("code", "");
          if (code.empty() || code == "INTERNAL" || code == "UNKNOWN") {
            Fail("a plan that failed with an undocumented code: " + data);
          }
        }
      }
      have_id = have_type = false;
      data_lines = 0;
      continue;
    }
    if (line.front() == ':' || absl::StartsWith(line, "retry: ")) continue;
    if (absl::StartsWith(line, "id: ")) {
      uint64_t id = 0;
      if (!absl::SimpleAtoi(line.substr(4), &id)) Fail("an event id that is not a number");
      if (any_id && id <= last_id) Fail("event ids that do not increase");
      any_id = have_id = true;
      last_id = id;
    } else if (absl::StartsWith(line, "event: ")) {
      type = std::string(line.substr(7));
      have_type = !type.empty();
    } else if (absl::StartsWith(line, "data: ")) {
      data = std::string(line.substr(6));
      ++data_lines;
    } else {
      Fail("a line of an event stream that is not an SSE field");
    }
  }
  if (terminal > 1) Fail("an event stream with more than one terminal event");
  return terminal;
}

// Serves one request and checks the answer; the id of the plan it started,
// if it started one.
std::string ServeOne(web::Gateway& gateway, MemoryServer& http, absl::string_view request) {
  MemoryStream stream(request);
  http.Serve(stream);
  if (stream.out().empty()) return "";  // cpp-httplib answers nothing to no request line
  const Response r = ParseResponse(stream.out());
  if (r.status < 200 || r.status > 599) Fail("a status outside [200, 599]");
  if (r.status == 500 || r.status == 502)
    Fail("status " + std::to_string(r.status) + ": " + r.body);
  if (gateway.open_viewers() != 0) Fail("a viewer still counted after its stream ended");
  // A HEAD answer has the headers of a GET and no body (RFC 9110 9.3.2).
  const bool head = absl::StartsWith(request, "HEAD ");
  if (absl::StartsWith(r.content_type, "application/json") && !head) CheckJson(r);
  if (absl::StartsWith(r.content_type, "text/event-stream") && r.status == 200 && !head) {
    const int terminal = CheckEventStream(r.body);
    // A stream read from the start ends with the plan's terminal event.
    const std::string lower = absl::AsciiStrToLower(request);
    if (terminal != 1 && !absl::StrContains(lower, "last_event_id") &&
        !absl::StrContains(lower, "last-event-id")) {
      Fail("an event stream read from the start without its terminal event");
    }
  }
  if (r.status == 201) {
    Json json = Json::parse(r.body, nullptr, /*allow_exceptions=*/false);
    if (!json.is_object() || !json["id"].is_string()) Fail("a started plan without its id");
    return json["id"].get<std::string>();
  }
  return "";
}

}  // namespace
}  // namespace riskplan::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace riskplan::fuzz;
  static Backend* const backend = new Backend();  // lives for the whole run
  const absl::string_view input(reinterpret_cast<const char*>(data), size);
  auto owned = std::make_unique<MemoryServer>();
  MemoryServer& http = *owned;
  riskplan::web::Gateway gateway(FuzzGatewayOptions(), backend->channel, std::move(owned));
  std::string plan_id = "00000000-0000-0000-0000-000000000000";
  size_t served = 0;
  for (absl::string_view request : absl::StrSplit(input, kSeparator)) {
    if (served++ == kMaxRequests) break;
    const std::string text = absl::StrReplaceAll(request, {{"@ID@", plan_id}});
    if (std::string id = ServeOne(gateway, http, text); !id.empty()) plan_id = id;
  }
  gateway.Stop();  // cancels the plans still running
  return 0;
}
