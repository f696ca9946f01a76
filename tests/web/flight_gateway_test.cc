// riskplan-web's flights (docs/web.md, "Flight"), against the real
// riskplan-server (the 2 km demo-city) and the real riskplan-web: the
// gateway flies a simulated aircraft along the Fly session's plan to the
// goal (versions, then positions of growing progress and time, then "ended"),
// a zone across the route ahead gives a new version whose route avoids it
// and whose committed prefix begins with the one before, a zone on the goal
// raises an alert with an emergency landing site, a refused opening arrives
// as the server wrote it, and the gateway's bounds (flights at once, zones,
// changes a second, speedup, inputs the page may send) are refused naming
// them. Nothing is timed: every wait is for an event, with generous
// deadlines.
#include <array>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/integration/server_process.h"
#include "tests/web/http_test_client.h"

namespace riskplan::testing {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;
using Json = nlohmann::json;

const absl::Duration kDeadline = absl::Seconds(180);

Json FlightBody(double speedup, double start_z = 240.0) {
  return Json{{"open",
               {{"plan",
                 {{"map", "demo-city"},
                  {"start", {{"x", 300}, {"y", 375}, {"z", start_z}, {"theta", 0.785}}},
                  {"goal", {{"x", 1700}, {"y", 1625}, {"z", 250}, {"theta", 0.785}}},
                  {"budget", {{"time_ms", "1000"}}}}}}},
              {"speedup", speedup}};
}

class FlightGatewayTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto server = ServerProcess::Start({"--rpc_log=false"});
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = server->release();
    auto web = ServerProcess::StartWeb(server_->address(),
                                       {"--max_flights=1", "--max_flight_zones=2", "--heartbeat_ms=100"});
    ASSERT_TRUE(web.ok()) << web.status();
    web_ = web->release();
  }
  static void TearDownTestSuite() {
    delete web_;
    delete server_;
    web_ = server_ = nullptr;
  }

  static HttpResponse Call(const std::string& method, const std::string& path,
                           const std::string& body = "") {
    auto response = HttpRequest(web_->address(), method, path, body, {}, kDeadline);
    EXPECT_TRUE(response.ok()) << response.status();
    return response.ok() ? *response : HttpResponse{};
  }
  static std::string StartFlight(const Json& body) {
    HttpResponse r = Call("POST", "/api/flights", body.dump());
    EXPECT_EQ(r.status, 201) << r.body;
    return r.status == 201 ? Json::parse(r.body)["id"].get<std::string>() : "";
  }
  static std::unique_ptr<SseStream> Events(const std::string& id) {
    auto stream = SseStream::Open(web_->address(), absl::StrCat("/api/flights/", id, "/events"), {},
                                  kDeadline);
    EXPECT_TRUE(stream.ok()) << stream.status();
    return stream.ok() ? *std::move(stream) : nullptr;
  }
  // Reads events until `done` holds for one of them (checked from the
  // stream's first event) or the stream ends: the events up to and including
  // the first for which it holds, else all read. One read may bring more
  // than the event sought (an alert and the position after it), so the one
  // sought is the last returned, not the stream's newest.
  template <typename F>
  static std::vector<SseEvent> ReadUntil(SseStream* stream, F done) {
    const absl::Time deadline = absl::Now() + kDeadline;
    size_t seen = 0;
    while (true) {
      const std::vector<SseEvent>& events = stream->events();
      for (; seen < events.size(); ++seen) {
        if (done(events[seen])) {
          return std::vector<SseEvent>(events.begin(), events.begin() + seen + 1);
        }
      }
      if (absl::Now() >= deadline || stream->ended()) return events;
      stream->ReadEvents(events.size() + 1, deadline - absl::Now());
    }
  }
  static void ExpectRefused(const HttpResponse& r, int status, const std::string& words) {
    EXPECT_EQ(r.status, status) << r.body;
    const Json j = Json::parse(r.body, nullptr, false);
    ASSERT_TRUE(j.is_object()) << r.body;
    EXPECT_EQ(j["source"], "gateway");
    EXPECT_THAT(j["message"].get<std::string>(), HasSubstr(words));
  }
  static void EndAndWait(const std::string& id, SseStream* stream) {
    Call("POST", absl::StrCat("/api/flights/", id, "/end"), "{}");
    ReadUntil(stream, [](const SseEvent& e) { return e.type == "ended" || e.type == "failed"; });
  }

  static inline ServerProcess* server_ = nullptr;
  static inline ServerProcess* web_ = nullptr;
};

// The route's display path with the arc length of each point (straight lines
// between its samples).
std::vector<std::array<double, 3>> RouteArc(const Json& route) {
  std::vector<std::array<double, 3>> out;
  double s = 0.0;
  for (size_t k = 0; k < route["path"].size(); ++k) {
    const Json& p = route["path"][k];
    if (k > 0) {
      const Json& q = route["path"][k - 1];
      s += std::hypot(p["x"].get<double>() - q["x"].get<double>(),
                      p["y"].get<double>() - q["y"].get<double>(),
                      p["z"].get<double>() - q["z"].get<double>());
    }
    out.push_back({p["x"].get<double>(), p["y"].get<double>(), s});
  }
  return out;
}

TEST_F(FlightGatewayTest, TheAircraftFliesItsPlanToTheGoal) {
  const std::string id = StartFlight(FlightBody(50.0));
  auto stream = Events(id);
  ASSERT_NE(stream, nullptr);
  ASSERT_TRUE(stream->ReadAll(kDeadline));
  const std::vector<SseEvent>& events = stream->events();
  ASSERT_GE(events.size(), 3u);
  EXPECT_EQ(events.front().type, "version");
  EXPECT_EQ(Json::parse(events.front().data)["version"]["reason"], "FLIGHT_REASON_OPENED");
  double time_s = 0.0, progress = 0.0, total = 0.0;
  int positions = 0;
  for (size_t k = 0; k < events.size(); ++k) {
    SCOPED_TRACE(k);
    EXPECT_EQ(events[k].id, std::to_string(k + 1));
    const Json d = Json::parse(events[k].data);
    if (events[k].type == "version") {
      total = d["version"]["committed_until_m"].get<double>() +
              d["version"]["remainder"]["length_m"].get<double>();
    } else if (events[k].type == "position") {
      ++positions;
      EXPECT_GT(d["time_s"].get<double>(), time_s);
      EXPECT_GT(d["progress_m"].get<double>(), progress);
      time_s = d["time_s"].get<double>();
      progress = d["progress_m"].get<double>();
      EXPECT_TRUE(d.contains("x") && d.contains("y") && d.contains("z"));
      EXPECT_FALSE(d.contains("lat_deg"));  // a local map
    } else {
      EXPECT_EQ(k + 1, events.size()) << events[k].type << ": " << events[k].data;
    }
  }
  EXPECT_GT(positions, 2);
  ASSERT_EQ(events.back().type, "ended");
  const Json end = Json::parse(events.back().data);
  EXPECT_EQ(end["message"], "the aircraft reached the goal");
  EXPECT_NEAR(end["progress_m"].get<double>(), total, 1e-6);
  EXPECT_EQ(Json::parse(Call("GET", absl::StrCat("/api/flights/", id)).body)["state"], "ended");
  // Ended: nothing more, ever.
  EXPECT_EQ(Call("GET", absl::StrCat("/api/flights/", id, "/events?last_event_id=",
                                     events.size()))
                .status,
            204);
}

TEST_F(FlightGatewayTest, AZoneAcrossTheRouteAheadGivesAVersionThatAvoidsIt) {
  const std::string id = StartFlight(FlightBody(2.0));
  auto stream = Events(id);
  ASSERT_NE(stream, nullptr);
  const auto& first =
      ReadUntil(stream.get(), [](const SseEvent& e) { return e.type != "position"; });
  ASSERT_FALSE(first.empty());
  ASSERT_EQ(first.back().type, "version") << first.back().data;
  const Json v1 = Json::parse(first.back().data)["version"];
  const auto arc = RouteArc(v1["route"]);
  const double until = v1["committed_until_m"].get<double>();
  const double target = until + 0.5 * (arc.back()[2] - until);
  std::array<double, 3> centre = arc.front();
  for (const auto& p : arc) {
    if (std::abs(p[2] - target) < std::abs(centre[2] - target)) centre = p;
  }
  constexpr double kRadius = 120.0;
  Json zone = {{"add_zone", {{"id", "fire"}, {"circle", {{"x", centre[0]}, {"y", centre[1]}, {"radius_m", kRadius}}}}}};
  HttpResponse r = Call("POST", absl::StrCat("/api/flights/", id, "/inputs"), zone.dump());
  ASSERT_EQ(r.status, 200) << r.body;
  Json before = v1, with_zone;
  ReadUntil(stream.get(), [&](const SseEvent& e) {
    if (e.type != "version") return e.type == "ended" || e.type == "failed";
    const Json v = Json::parse(e.data)["version"];
    for (const Json& z : v["active_zones"]) {
      if (z == "fire") {
        with_zone = v;
        return true;
      }
    }
    before = v;
    return false;
  });
  ASSERT_TRUE(with_zone.is_object()) << "no version with the zone";
  EXPECT_EQ(with_zone["reason"], "FLIGHT_REASON_ZONE_ADDED");
  for (const Json& p : with_zone["route"]["path"]) {
    EXPECT_GT(std::hypot(p["x"].get<double>() - centre[0], p["y"].get<double>() - centre[1]),
              kRadius);
  }
  // What was committed stays committed.
  const Json& old_committed = before["committed"];
  const Json& new_committed = with_zone["committed"];
  ASSERT_GE(new_committed.size(), old_committed.size());
  for (size_t k = 0; k < old_committed.size(); ++k) EXPECT_EQ(new_committed[k], old_committed[k]);

  // A zone on the goal: no remainder; an alert with its landing site.
  zone = {{"add_zone", {{"id", "goal"}, {"circle", {{"x", 1700}, {"y", 1625}, {"radius_m", 150}}}}}};
  r = Call("POST", absl::StrCat("/api/flights/", id, "/inputs"), zone.dump());
  ASSERT_EQ(r.status, 200) << r.body;
  const auto& events = ReadUntil(stream.get(), [](const SseEvent& e) {
    return e.type == "alert" || e.type == "ended" || e.type == "failed";
  });
  ASSERT_EQ(events.back().type, "alert") << events.back().data;
  const Json alert = Json::parse(events.back().data)["alert"];
  EXPECT_EQ(alert["kind"], "FLIGHT_ALERT_NO_REMAINDER");
  EXPECT_THAT(alert["detail"].get<std::string>(), HasSubstr("NO_FLY_ZONE"));
  EXPECT_TRUE(alert.contains("landing") && alert["landing"].contains("site_pose")) << alert.dump();
  EndAndWait(id, stream.get());
  EXPECT_EQ(stream->events().back().type, "ended");
  EXPECT_EQ(Json::parse(stream->events().back().data)["message"], "ended from the page");
}

TEST_F(FlightGatewayTest, ARefusedOpeningArrivesAsTheServerWroteIt) {
  // A commit horizon out of range: the server ends the stream with its
  // INVALID_ARGUMENT naming the field, passed on untouched.
  Json body = FlightBody(10.0);
  body["open"]["commit_horizon_s"] = 700;
  std::string id = StartFlight(body);
  auto stream = Events(id);
  ASSERT_NE(stream, nullptr);
  ASSERT_TRUE(stream->ReadAll(kDeadline));
  ASSERT_FALSE(stream->events().empty());
  ASSERT_EQ(stream->events().back().type, "failed") << stream->events().back().data;
  const Json d = Json::parse(stream->events().back().data);
  EXPECT_EQ(d["code"], "INVALID_ARGUMENT");
  EXPECT_THAT(d["message"].get<std::string>(), HasSubstr("commit_horizon_s"));
  EXPECT_EQ(Json::parse(Call("GET", absl::StrCat("/api/flights/", id)).body)["state"], "failed");

  // A start below the terrain is no error of the opening: the session
  // stays open with an alert (no remainder from there) until the page ends it.
  id = StartFlight(FlightBody(10.0, 100.0));
  stream = Events(id);
  ASSERT_NE(stream, nullptr);
  ReadUntil(stream.get(), [](const SseEvent& e) { return e.type != "position"; });
  ASSERT_EQ(stream->events().back().type, "alert") << stream->events().back().data;
  EXPECT_THAT(Json::parse(stream->events().back().data)["alert"]["detail"].get<std::string>(),
              HasSubstr("TERRAIN_COLLISION"));
  EndAndWait(id, stream.get());
  EXPECT_EQ(stream->events().back().type, "ended") << stream->events().back().data;
}

TEST_F(FlightGatewayTest, TheGatewaysBoundsAreRefusedNamingThem) {
  ExpectRefused(Call("POST", "/api/flights", FlightBody(0.5).dump()), 400,
                "speedup has value 0.5; it must be in [1, 100]");
  Json unknown = FlightBody(10.0);
  unknown["fast"] = true;
  ExpectRefused(Call("POST", "/api/flights", unknown.dump()), 400, "unknown field 'fast'");
  Json outside = FlightBody(10.0);
  outside["open"]["plan"]["start"]["x"] = 5000;
  ExpectRefused(Call("POST", "/api/flights", outside.dump()), 400,
                "open.plan: start (x, y) = (5000.0, 375.0) m is outside map 'demo-city'");
  Json resume = FlightBody(10.0);
  resume["open"]["resume"] = true;
  ExpectRefused(Call("POST", "/api/flights", resume.dump()), 400, "open.resume and open.route");
  ExpectRefused(Call("POST", "/api/flights/f0-00/inputs", "{}"), 404, "no flight 'f0-00'");

  const std::string id = StartFlight(FlightBody(1.0));
  auto stream = Events(id);
  ASSERT_NE(stream, nullptr);
  ReadUntil(stream.get(), [](const SseEvent& e) { return e.type != "position"; });
  ASSERT_EQ(stream->events().back().type, "version") << stream->events().back().data;
  // One flight at once on this gateway (--max_flights=1).
  ExpectRefused(Call("POST", "/api/flights", FlightBody(10.0).dump()), 429,
                "this gateway flies at most 1 flights at once (--max_flights)");
  const std::string inputs = absl::StrCat("/api/flights/", id, "/inputs");
  ExpectRefused(Call("POST", inputs, R"({"position": {"time_s": 1, "progress_m": 5}})"), 400,
                "the page sends add_zone, remove_zone or wind");
  // Two zones at once (--max_flight_zones=2), small and out of the way.
  for (const char* z : {"a", "b", "c"}) {
    const Json zone = {{"add_zone", {{"id", z}, {"circle", {{"x", 100}, {"y", 1900}, {"radius_m", 20}}}}}};
    HttpResponse r = Call("POST", inputs, zone.dump());
    if (std::string(z) == "c") {
      ExpectRefused(r, 429, "this gateway holds at most 2 zones on one flight (--max_flight_zones)");
    } else {
      EXPECT_EQ(r.status, 200) << r.body;
    }
  }
  // Four changes a second, in bursts of four: sent back to back, one is
  // soon refused.
  bool refused = false;
  for (int k = 0; k < 50 && !refused; ++k) {
    HttpResponse r = Call("POST", inputs, R"({"remove_zone": {"id": "nothing"}})");
    if (r.status == 429) {
      refused = true;
      ExpectRefused(r, 429, "at most 4 zone or wind changes a second on one flight");
    } else {
      EXPECT_EQ(r.status, 200) << r.body;
    }
  }
  EXPECT_TRUE(refused);
  // The server's refusal of a removal of no zone arrives as an event.
  ReadUntil(stream.get(), [](const SseEvent& e) { return e.type == "refusal"; });
  ASSERT_EQ(stream->events().back().type, "refusal");
  EXPECT_THAT(Json::parse(stream->events().back().data)["refusal"]["message"].get<std::string>(),
              HasSubstr("nothing"));
  EndAndWait(id, stream.get());
  ExpectRefused(Call("POST", inputs, R"({"remove_zone": {"id": "a"}})"), 412, "has ended");
}

}  // namespace
}  // namespace riskplan::testing
