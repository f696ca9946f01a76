// riskplan-web's HTTP and Server-Sent Events handling, against the real
// riskplan-server (the 2 km demo-city) and the real riskplan-web, both on
// port 0: a plan's events on the wire, a reconnection with Last-Event-ID, the
// viewer limit and the running-plan limit with their refusals, cancellation
// reaching the server, bad requests, and the server's errors passed on as the
// server wrote them. Plans use iteration budgets (reproducible) or are
// cancelled; deadlines are generous and nothing is timed.
#include <signal.h>
#include <zlib.h>

#include <map>
#include <memory>
#include <regex>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/time/clock.h"
#include "client/client.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/integration/server_process.h"
#include "tests/web/http_test_client.h"

namespace riskplan::testing {
namespace {

using ::testing::HasSubstr;
using Json = nlohmann::json;

constexpr int kMaxViewers = 3;
constexpr int kMaxRunningPlans = 2;
const absl::Duration kDeadline = absl::Seconds(120);

// A plan across the small demo-city (tests/integration/server_process.h).
Json PlanBody(int64_t iterations, int64_t time_ms = 0, double start_z = 240.0) {
  return Json{{"map", "demo-city"},
              {"start", {{"x", 300}, {"y", 375}, {"z", start_z}, {"theta", 0.785}}},
              {"goal", {{"x", 1700}, {"y", 1625}, {"z", 250}, {"theta", 0.785}}},
              {"budget", {{"iterations", std::to_string(iterations)}, {"time_ms", std::to_string(time_ms)}}},
              {"seed", "7"}};
}

class GatewayTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto server = ServerProcess::Start({"--metrics_listen=127.0.0.1:0", "--rpc_log=false"});
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = server->release();
    auto web = ServerProcess::StartWeb(
        server_->address(),
        {absl::StrCat("--max_viewers=", kMaxViewers),
         absl::StrCat("--max_running_plans=", kMaxRunningPlans), "--heartbeat_ms=100"});
    ASSERT_TRUE(web.ok()) << web.status();
    web_ = web->release();
  }
  static void TearDownTestSuite() {
    delete web_;
    delete server_;
  }

  static HttpResponse Call(const std::string& method, const std::string& path,
                           const std::string& body = "",
                           const std::map<std::string, std::string>& headers = {}) {
    auto response = HttpRequest(web_->address(), method, path, body, headers, kDeadline);
    EXPECT_TRUE(response.ok()) << response.status();
    return response.ok() ? *response : HttpResponse{};
  }

  // Starts a plan; its id.
  static std::string StartPlan(const Json& body) {
    HttpResponse r = Call("POST", "/api/plans", body.dump());
    EXPECT_EQ(r.status, 201) << r.body;
    return r.status == 201 ? Json::parse(r.body)["id"].get<std::string>() : "";
  }

  static std::string EventsPath(const std::string& id) {
    return absl::StrCat("/api/plans/", id, "/events");
  }

  // Every event of a plan, read to the stream's end.
  static std::vector<SseEvent> AllEvents(const std::string& id,
                                         const std::map<std::string, std::string>& headers = {}) {
    auto stream = SseStream::Open(web_->address(), EventsPath(id), headers, kDeadline);
    EXPECT_TRUE(stream.ok()) << stream.status();
    if (!stream.ok()) return {};
    EXPECT_EQ((*stream)->response().status, 200);
    EXPECT_TRUE((*stream)->ReadAll(kDeadline));
    return (*stream)->events();
  }

  static Json Status() { return Json::parse(Call("GET", "/api/status").body); }

  static double RunningPlansOnServer() {
    const std::string metrics = MetricsAddress(server_->Stderr());
    auto text = HttpGet(metrics, "/metrics");
    EXPECT_TRUE(text.ok()) << text.status();
    return MetricValue(text.ok() ? *text : "", "riskplan_running_plans").value_or(-1);
  }

  // Polls `condition` every 20 ms up to the deadline.
  template <typename F>
  static bool Eventually(F condition) {
    const absl::Time deadline = absl::Now() + kDeadline;
    while (absl::Now() < deadline) {
      if (condition()) return true;
      absl::SleepFor(absl::Milliseconds(20));
    }
    return condition();
  }

  static inline ServerProcess* server_ = nullptr;
  static inline ServerProcess* web_ = nullptr;
};

TEST_F(GatewayTest, APlanStreamsNumberedImprovementsThenItsFinalMessage) {
  const std::string id = StartPlan(PlanBody(400));
  auto stream = SseStream::Open(web_->address(), EventsPath(id), {}, kDeadline);
  ASSERT_TRUE(stream.ok()) << stream.status();
  const HttpResponse& head = (*stream)->response();
  EXPECT_EQ(head.status, 200);
  EXPECT_EQ(head.headers.at("content-type"), "text/event-stream");
  EXPECT_EQ(head.headers.at("cache-control"), "no-store");
  ASSERT_TRUE((*stream)->ReadAll(kDeadline));
  EXPECT_EQ((*stream)->retry_ms(), 1000);
  const std::vector<SseEvent>& events = (*stream)->events();
  ASSERT_GE(events.size(), 2u);
  double last_risk = 1e300;
  for (size_t k = 0; k < events.size(); ++k) {
    SCOPED_TRACE(k);
    EXPECT_EQ(events[k].id, std::to_string(k + 1));
    EXPECT_EQ(events[k].type, k + 1 == events.size() ? "final" : "update");
    const Json data = Json::parse(events[k].data);
    EXPECT_GT(data["gateway_ms"].get<double>(), 1.6e12);  // ms since 1970, after 2020
    const Json& update = data["update"];
    // The server's own sequence numbers: none lost between server and page.
    EXPECT_EQ(update["sequence"], std::to_string(k + 1));
    const double risk = update["trajectory"]["risk"].get<double>();
    EXPECT_LE(risk, last_risk);
    last_risk = risk;
  }
  const Json final_update = Json::parse(events.back().data)["update"];
  EXPECT_EQ(final_update["final"], true);
  EXPECT_EQ(final_update["end_reason"], "BUDGET_EXHAUSTED");
  EXPECT_EQ(final_update["iterations"], "400");
  EXPECT_EQ(Json::parse(Call("GET", "/api/plans/" + id).body)["state"], "finished");
}

TEST_F(GatewayTest, AReconnectingViewerResumesAfterItsLastEventId) {
  const std::string id = StartPlan(PlanBody(300));
  const std::vector<SseEvent> all = AllEvents(id);
  ASSERT_GE(all.size(), 4u);
  const size_t n = all.size();
  for (size_t seen : {size_t{1}, n / 2, n - 1}) {
    SCOPED_TRACE(seen);
    // What EventSource sends, and the page's own query form.
    for (bool header : {true, false}) {
      std::vector<SseEvent> rest;
      if (header) {
        rest = AllEvents(id, {{"Last-Event-ID", std::to_string(seen)}});
      } else {
        auto stream = SseStream::Open(web_->address(),
                                      absl::StrCat(EventsPath(id), "?last_event_id=", seen), {},
                                      kDeadline);
        ASSERT_TRUE(stream.ok());
        ASSERT_TRUE((*stream)->ReadAll(kDeadline));
        rest = (*stream)->events();
      }
      ASSERT_EQ(rest.size(), n - seen);
      for (size_t k = 0; k < rest.size(); ++k) {
        EXPECT_EQ(rest[k].id, all[seen + k].id);
        EXPECT_EQ(rest[k].type, all[seen + k].type);
        EXPECT_EQ(rest[k].data, all[seen + k].data);
      }
    }
  }
  // Everything seen of an ended plan: 204, which tells a browser to stop
  // reconnecting.
  HttpResponse done = Call("GET", EventsPath(id), "", {{"Last-Event-ID", std::to_string(n)}});
  EXPECT_EQ(done.status, 204);
  HttpResponse bad = Call("GET", EventsPath(id), "", {{"Last-Event-ID", "12abc"}});
  EXPECT_EQ(bad.status, 400);
  EXPECT_THAT(bad.body, HasSubstr("Last-Event-ID has value '12abc'"));
}

TEST_F(GatewayTest, ViewersPastTheLimitAreRefusedUntilOneLeaves) {
  // A plan that runs until it is cancelled, so that streams stay open.
  const std::string id = StartPlan(PlanBody(0, 600000));
  std::vector<std::unique_ptr<SseStream>> viewers;
  for (int k = 0; k < kMaxViewers; ++k) {
    auto stream = SseStream::Open(web_->address(), EventsPath(id), {}, kDeadline);
    ASSERT_TRUE(stream.ok()) << stream.status();
    ASSERT_EQ((*stream)->response().status, 200);
    ASSERT_TRUE((*stream)->ReadEvents(1, kDeadline));
    viewers.push_back(std::move(*stream));
  }
  EXPECT_EQ(Status()["viewers"], kMaxViewers);
  HttpResponse refused = Call("GET", EventsPath(id));
  EXPECT_EQ(refused.status, 503);
  EXPECT_EQ(refused.headers["retry-after"], "5");
  const Json error = Json::parse(refused.body);
  EXPECT_EQ(error["code"], "RESOURCE_EXHAUSTED");
  EXPECT_EQ(error["source"], "gateway");
  EXPECT_EQ(error["message"],
            absl::StrFormat("this gateway holds at most %d event streams at once (--max_viewers) "
                            "and all are open; try again when a viewer has closed",
                            kMaxViewers));
  // The other routes still answer while every viewer slot is taken.
  EXPECT_EQ(Call("GET", "/api/maps").status, 200);

  // One viewer leaves; the gateway finds out at its next write (a heartbeat
  // at the latest) and lets a new one in.
  viewers.back()->Close();
  viewers.pop_back();
  ASSERT_TRUE(Eventually([] { return Status()["viewers"] == kMaxViewers - 1; }));
  auto again = SseStream::Open(web_->address(), EventsPath(id), {}, kDeadline);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ((*again)->response().status, 200);
  viewers.push_back(std::move(*again));

  // Cancelled: every viewer gets the "cancelled" event and its stream ends.
  EXPECT_EQ(Json::parse(Call("POST", "/api/plans/" + id + "/cancel").body)["cancelled"], true);
  for (auto& v : viewers) {
    ASSERT_TRUE(v->ReadAll(kDeadline));
    ASSERT_FALSE(v->events().empty());
    EXPECT_EQ(v->events().back().type, "cancelled");
  }
  EXPECT_TRUE(Eventually([] { return Status()["viewers"] == 0; }));
}

TEST_F(GatewayTest, CancelStopsThePlanOnTheServer) {
  const std::string id = StartPlan(PlanBody(0, 600000));
  auto stream = SseStream::Open(web_->address(), EventsPath(id), {}, kDeadline);
  ASSERT_TRUE(stream.ok());
  ASSERT_TRUE((*stream)->ReadEvents(1, kDeadline));
  EXPECT_TRUE(Eventually([] { return RunningPlansOnServer() == 1; }));
  EXPECT_EQ(Json::parse(Call("POST", "/api/plans/" + id + "/cancel").body)["cancelled"], true);
  ASSERT_TRUE((*stream)->ReadAll(kDeadline));
  EXPECT_EQ((*stream)->events().back().type, "cancelled");
  EXPECT_TRUE(Eventually([] { return RunningPlansOnServer() == 0; }));
  EXPECT_EQ(Json::parse(Call("GET", "/api/plans/" + id).body)["state"], "cancelled");
  // A second cancel has nothing left to stop.
  EXPECT_EQ(Json::parse(Call("POST", "/api/plans/" + id + "/cancel").body)["cancelled"], false);
}

TEST_F(GatewayTest, PlansPastTheRunningLimitAreRefused) {
  std::vector<std::string> ids;
  for (int k = 0; k < kMaxRunningPlans; ++k) ids.push_back(StartPlan(PlanBody(0, 600000)));
  HttpResponse refused = Call("POST", "/api/plans", PlanBody(100).dump());
  EXPECT_EQ(refused.status, 429);
  EXPECT_THAT(Json::parse(refused.body)["message"].get<std::string>(),
              HasSubstr(absl::StrFormat("at most %d plans at once (--max_running_plans)",
                                        kMaxRunningPlans)));
  for (const std::string& id : ids) Call("POST", "/api/plans/" + id + "/cancel");
  EXPECT_TRUE(Eventually([] { return Status()["running_plans"] == 0; }));
  EXPECT_EQ(Call("POST", "/api/plans", PlanBody(50).dump()).status, 201);
}

TEST_F(GatewayTest, TheServersRefusalArrivesAsTheServerWroteIt) {
  // The same request straight to the server, through the client library.
  v1::PlanRequest request;
  request.set_map("demo-city");
  *request.mutable_start() = [] {
    v1::Pose p;
    p.set_x(300), p.set_y(375), p.set_z(100), p.set_theta(0.785);
    return p;
  }();
  *request.mutable_goal() = [] {
    v1::Pose p;
    p.set_x(1700), p.set_y(1625), p.set_z(250), p.set_theta(0.785);
    return p;
  }();
  request.mutable_budget()->set_iterations(10);
  client::RiskplanClient direct(server_->Channel());  // TLS and token when the suite uses them
  const grpc::Status expected = direct.Plan(request, [](const v1::PlanUpdate&) { return true; });
  ASSERT_EQ(expected.error_code(), grpc::StatusCode::INVALID_ARGUMENT);

  const std::string id = StartPlan(PlanBody(10, 0, /*start_z=*/100));
  const std::vector<SseEvent> events = AllEvents(id);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].type, "failed");
  const Json error = Json::parse(events[0].data);
  EXPECT_EQ(error["code"], "INVALID_ARGUMENT");
  EXPECT_EQ(error["message"], expected.error_message());
  EXPECT_THAT(expected.error_message(), HasSubstr("start pose (300.0, 375.0, 100.0)"));

  // A unary call's error too: an unknown map.
  HttpResponse r = Call("POST", "/api/evaluate",
                        R"({"map":"atlantis","polyline":{"points":[{"x":1,"y":1,"z":250},)"
                        R"({"x":2,"y":2,"z":250}]}})");
  EXPECT_EQ(r.status, 404);
  v1::EvaluateRiskRequest eval;
  eval.set_map("atlantis");
  for (double x : {1.0, 2.0}) {
    v1::Point3* p = eval.mutable_polyline()->add_points();
    p->set_x(x), p->set_y(x), p->set_z(250);
  }
  v1::EvaluateRiskResponse ignored;
  const grpc::Status eval_expected = direct.EvaluateRisk(eval, &ignored);
  const Json body = Json::parse(r.body);
  EXPECT_EQ(body["code"], "NOT_FOUND");
  EXPECT_EQ(body["source"], "server");
  EXPECT_EQ(body["message"], eval_expected.error_message());
}

TEST_F(GatewayTest, BadRequestsAreRefusedNamingWhatIsWrong) {
  struct Case {
    std::string method, path, body;
    int status;
    std::string message_part;
  };
  const std::vector<Case> cases = {
      {"POST", "/api/plans", "not json", 400, "the body is not a PlanRequest in JSON"},
      {"POST", "/api/plans", R"({"mapp":"demo-city"})", 400, "mapp"},
      {"POST", "/api/evaluate", "[1,2]", 400, "the body is not a EvaluateRiskRequest in JSON"},
      {"POST", "/api/risk_layer", R"({"map":"demo-city","stride":"x"})", 400,
       "the body is not a GetRiskLayerRequest in JSON"},
      {"GET", "/api/layer?map=demo-city&layer=LAVA", "", 400, "layer has value 'LAVA'"},
      {"GET", "/api/layer?map=demo-city&layer=TERRAIN&max_side_cells=big", "", 400,
       "max_side_cells must be an integer"},
      {"GET", "/api/layer?map=demo-city&layer=TERRAIN&max_side_cells=4096", "", 400,
       "max_side_cells has value 4096; this gateway serves layers of at most 1024 cells a side"},
      // The server's own range check, passed on.
      {"GET", "/api/layer?map=demo-city&layer=TERRAIN&max_side_cells=-3", "", 400,
       "max_side_cells"},
      {"GET", "/api/plans/0123abcd-ff/events", "", 404, "no plan '0123abcd-ff' on this gateway"},
      {"POST", "/api/plans/0123abcd-ff/cancel", "", 404, "no plan '0123abcd-ff'"},
      {"POST", "/api/export?format=docx", "{}", 400, "format has value 'docx'"},
      // demo-city has no geo-reference: nothing in WGS84 to export.
      {"POST", "/api/export?format=geojson",
       R"({"map":"demo-city","waypoints":{"poses":[{"x":300,"y":375,"z":240,"theta":0.785},)"
       R"({"x":1700,"y":1625,"z":250,"theta":0.785}]}})",
       412, "map 'demo-city' has no geo-reference"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.method + " " + c.path + " " + c.body);
    HttpResponse r = Call(c.method, c.path, c.body);
    EXPECT_EQ(r.status, c.status);
    EXPECT_THAT(Json::parse(r.body)["message"].get<std::string>(), HasSubstr(c.message_part));
  }
  // A body larger than the gateway accepts (4 MiB) is refused before
  // parsing, with the {code, message} of every refusal.
  HttpResponse big = Call("POST", "/api/evaluate", std::string(5 << 20, ' '));
  EXPECT_EQ(big.status, 413);
  ASSERT_FALSE(big.body.empty());
  const Json too_big = Json::parse(big.body);
  EXPECT_EQ(too_big["code"], "RESOURCE_EXHAUSTED");
  EXPECT_EQ(too_big["message"],
            "the request body is larger than this gateway accepts (4194304 bytes at most)");
  EXPECT_EQ(too_big["source"], "gateway");
  // So does a path that is nothing.
  HttpResponse nothing = Call("GET", "/no-such-page.html");
  EXPECT_EQ(nothing.status, 404);
  EXPECT_EQ(Json::parse(nothing.body)["message"],
            "no page, file or route GET /no-such-page.html on this gateway");
}

// What the server would refuse at once is refused before the plan starts:
// 400 (404 for a map the server does not have) with the message, never 201
// and then a "failed" event.
TEST_F(GatewayTest, APlanTheServerWouldRefuseIsRefusedBeforeItStarts) {
  // Plans of earlier tests may still be ending (slowly, under a sanitizer):
  // none of these requests may add one.
  const int running_before = Json::parse(Call("GET", "/api/status").body)["running_plans"];
  struct Case {
    Json body;
    int status;
    std::string message;
  };
  Json outside = PlanBody(10);
  outside["start"]["x"] = 5000;
  Json goal_outside = PlanBody(10);
  goal_outside["goal"]["y"] = -10;
  Json long_budget = PlanBody(0, 700000);
  Json negative = PlanBody(-5);
  Json atlantis = PlanBody(10);
  atlantis["map"] = "atlantis";
  Json no_goal = PlanBody(10);
  no_goal.erase("goal");
  const std::vector<Case> cases = {
      {outside, 400,
       "start (x, y) = (5000.0, 375.0) m is outside map 'demo-city' (x 0.0 .. 2000.0 m, y 0.0 .. "
       "2000.0 m)"},
      {goal_outside, 400,
       "goal (x, y) = (1700.0, -10.0) m is outside map 'demo-city' (x 0.0 .. 2000.0 m, y 0.0 .. "
       "2000.0 m)"},
      {long_budget, 400,
       "budget.time_ms has value 700000; it must be in [0, 600000] (0: no time limit; this "
       "gateway's --max_plan_time_ms)"},
      {negative, 400, "budget.iterations has value -5; it must be >= 0 (0: no iteration limit)"},
      {atlantis, 404, "map 'atlantis' is not on the server (it has: demo-city)"},
      {no_goal, 400, "goal (or goal_wgs84) is required"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.body.dump());
    HttpResponse r = Call("POST", "/api/plans", c.body.dump());
    EXPECT_EQ(r.status, c.status) << r.body;
    const Json error = Json::parse(r.body);
    EXPECT_EQ(error["message"], c.message);
    EXPECT_EQ(error["source"], "gateway");
  }
  // No plan was started for any of them.
  EXPECT_LE(Json::parse(Call("GET", "/api/status").body)["running_plans"].get<int>(),
            running_before);
}

// The layers are gzipped by the gateway (cpp-httplib would answer a browser
// that takes Brotli with Brotli at its slowest level, seconds a layer), and
// a layer asked again is the same bytes, made once.
TEST_F(GatewayTest, LayersAreGzippedNotBrotliAndTheSameWhenAskedAgain) {
  ASSERT_EQ(Call("GET", "/api/maps").status, 200);
  const std::string path = "/api/layer?map=demo-city&layer=POPULATION_DENSITY&max_side_cells=400";
  const HttpResponse plain = Call("GET", path);
  ASSERT_EQ(plain.status, 200) << plain.body;
  EXPECT_EQ(plain.headers.count("content-encoding"), 0u);
  const std::map<std::string, std::string> chromium = {
      {"Accept-Encoding", "gzip, deflate, br"}};
  const HttpResponse first = Call("GET", path, "", chromium);
  const HttpResponse second = Call("GET", path, "", chromium);
  ASSERT_EQ(first.status, 200);
  EXPECT_EQ(first.headers.at("content-encoding"), "gzip");
  EXPECT_EQ(first.headers.at("content-type"), "application/json");
  EXPECT_EQ(second.body, first.body);
  EXPECT_LT(first.body.size(), plain.body.size() / 2);
  // It unzips to the plain answer, byte for byte.
  z_stream z{};
  ASSERT_EQ(inflateInit2(&z, 15 + 16), Z_OK);
  std::string unzipped(plain.body.size() + 16, '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(first.body.data()));
  z.avail_in = static_cast<uInt>(first.body.size());
  z.next_out = reinterpret_cast<Bytef*>(unzipped.data());
  z.avail_out = static_cast<uInt>(unzipped.size());
  EXPECT_EQ(inflate(&z, Z_FINISH), Z_STREAM_END);
  unzipped.resize(z.total_out);
  inflateEnd(&z);
  EXPECT_EQ(unzipped, plain.body);
  // Nothing else is compressed by Brotli either (the page's scripts).
  const HttpResponse script = Call("GET", "/app.js", "", chromium);
  ASSERT_EQ(script.status, 200);
  EXPECT_NE(script.headers.count("content-encoding") ? script.headers.at("content-encoding") : "",
            "br");
}

TEST_F(GatewayTest, TheFaviconIsThePagesOwn) {
  const HttpResponse ico = Call("GET", "/favicon.ico");
  EXPECT_EQ(ico.status, 200);
  EXPECT_EQ(ico.headers.at("content-type"), "image/svg+xml");
  EXPECT_THAT(ico.body, ::testing::StartsWith("<svg"));
  const HttpResponse svg = Call("GET", "/favicon.svg");
  EXPECT_EQ(svg.status, 200);
  EXPECT_EQ(svg.body, ico.body);
  EXPECT_THAT(Call("GET", "/").body, HasSubstr("<link rel=\"icon\" href=\"/favicon.svg\""));
}

TEST_F(GatewayTest, APlanKeepsItsNewestEventsWithinItsBound) {
  // A gateway of its own, keeping 5 events a plan.
  auto small = ServerProcess::StartWeb(server_->address(), {"--max_events_per_plan=5"});
  ASSERT_TRUE(small.ok()) << small.status();
  auto call = [&](const std::string& method, const std::string& path, const std::string& body,
                  const std::map<std::string, std::string>& headers = {}) {
    auto r = HttpRequest((*small)->address(), method, path, body, headers, kDeadline);
    EXPECT_TRUE(r.ok()) << r.status();
    return r.ok() ? *r : HttpResponse{};
  };
  const std::string id =
      Json::parse(call("POST", "/api/plans", PlanBody(300).dump()).body)["id"].get<std::string>();
  ASSERT_TRUE(Eventually([&] {
    return Json::parse(call("GET", "/api/plans/" + id, "").body)["state"] == "finished";
  }));
  const Json info = Json::parse(call("GET", "/api/plans/" + id, "").body);
  const uint64_t last = info["last_event_id"].get<uint64_t>();
  ASSERT_GT(last, 5u);
  EXPECT_EQ(info["first_kept_event_id"].get<uint64_t>(), last - 4);
  EXPECT_EQ(info["last_kept_event_id"].get<uint64_t>(), last);
  // A viewer from the start, or resuming from an id no longer kept, gets the
  // five newest: the newest improvements and the final message.
  for (const std::string& seen : {std::string("0"), std::string("1")}) {
    auto stream = SseStream::Open((*small)->address(), EventsPath(id), {{"Last-Event-ID", seen}},
                                  kDeadline);
    ASSERT_TRUE(stream.ok());
    ASSERT_TRUE((*stream)->ReadAll(kDeadline));
    const std::vector<SseEvent>& events = (*stream)->events();
    ASSERT_EQ(events.size(), 5u);
    EXPECT_EQ(events.front().id, std::to_string(last - 4));
    EXPECT_EQ(events.back().id, std::to_string(last));
    EXPECT_EQ(events.back().type, "final");
  }
}

TEST_F(GatewayTest, SigtermEndsOpenStreamsCancelsPlansAndExitsZero) {
  auto own = ServerProcess::StartWeb(server_->address(), {"--heartbeat_ms=60000"});
  ASSERT_TRUE(own.ok()) << own.status();
  auto r = HttpRequest((*own)->address(), "POST", "/api/plans", PlanBody(0, 600000).dump(), {},
                       kDeadline);
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(r->status, 201);
  const std::string id = Json::parse(r->body)["id"].get<std::string>();
  // Two viewers waiting on the plan (the heartbeat would not wake them).
  std::vector<std::unique_ptr<SseStream>> viewers;
  for (int k = 0; k < 2; ++k) {
    auto stream = SseStream::Open((*own)->address(), EventsPath(id), {}, kDeadline);
    ASSERT_TRUE(stream.ok());
    ASSERT_TRUE((*stream)->ReadEvents(1, kDeadline));
    viewers.push_back(std::move(*stream));
  }
  ASSERT_TRUE(Eventually([] { return RunningPlansOnServer() == 1; }));
  (*own)->Signal(SIGTERM);
  EXPECT_EQ((*own)->Wait(absl::Seconds(60)), 0);
  for (auto& v : viewers) EXPECT_TRUE(v->ReadAll(kDeadline));
  // The gateway cancelled its plan on the server before it exited.
  EXPECT_TRUE(Eventually([] { return RunningPlansOnServer() == 0; }));
}

TEST_F(GatewayTest, ServesThePageAndItsLibrariesFromDebian) {
  HttpResponse page = Call("GET", "/");
  EXPECT_EQ(page.status, 200);
  EXPECT_THAT(page.body, HasSubstr("/lib/leaflet/leaflet.js"));
  EXPECT_EQ(Call("GET", "/app.js").status, 200);
  // And every script of the page's own, as index.html names them.
  const std::regex own_script(R"re(<script src="(/[a-z_]+\.js)"></script>)re");
  int own_scripts = 0;
  for (std::sregex_iterator it(page.body.begin(), page.body.end(), own_script), end; it != end;
       ++it) {
    EXPECT_EQ(Call("GET", (*it)[1].str()).status, 200) << (*it)[1].str();
    ++own_scripts;
  }
  EXPECT_GE(own_scripts, 8);
  EXPECT_THAT(Call("GET", "/lib/leaflet/leaflet.js").body, HasSubstr("Leaflet"));
  EXPECT_THAT(Call("GET", "/lib/chart.js/chart.min.js").body, HasSubstr("Chart.js"));
  // No script or style from anywhere but the gateway itself.
  EXPECT_THAT(page.body, ::testing::Not(HasSubstr("http://")));
  EXPECT_THAT(page.body, ::testing::Not(HasSubstr("https://")));
  // Maps and layers in the API's JSON form.
  const Json maps = Json::parse(Call("GET", "/api/maps").body);
  EXPECT_EQ(maps["maps"][0]["name"], "demo-city");
  const Json layer =
      Json::parse(Call("GET", "/api/layer?map=demo-city&layer=NO_FLY&max_side_cells=8").body);
  EXPECT_EQ(layer["nx"], 8);
  EXPECT_EQ(layer["values"].size(), 64u);
}

}  // namespace
}  // namespace riskplan::testing
