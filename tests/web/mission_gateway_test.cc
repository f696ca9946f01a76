// riskplan-web's QGroundControl missions (docs/web.md, "Missions"), against
// the real riskplan-server on a 2 km demo-city placed on WGS84 (and the same
// city without a geo-reference) and the real riskplan-web: a .plan read for
// the page (its points, legs, headings and the limits of its "riskplan"
// section), bad files refused naming what is wrong, a mission planned leg by
// leg through the event stream (every leg's updates, then the joined
// trajectory from the takeoff through the waypoint to the landing), within
// the whole mission's endurance, an endurance no mission meets ending with a
// note naming the leg, and the planned mission written back as a .plan that
// reads back as the same mission with its limits. Iteration budgets only;
// nothing is timed.
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/qgc_plan_testing.h"
#include "tests/integration/server_process.h"
#include "tests/web/http_test_client.h"

namespace riskplan::testing {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;
using Json = nlohmann::json;

const absl::Duration kDeadline = absl::Seconds(180);
constexpr double kSizeM = 2000.0;

// Great-circle distance, m (a sphere: millimetres over metres).
double GroundDistanceM(double lat1, double lon1, double lat2, double lon2) {
  constexpr double kDeg = M_PI / 180.0;
  const double p1 = lat1 * kDeg, p2 = lat2 * kDeg;
  const double dp = p2 - p1, dl = (lon2 - lon1) * kDeg;
  const double h = std::sin(dp / 2) * std::sin(dp / 2) +
                   std::cos(p1) * std::cos(p2) * std::sin(dl / 2) * std::sin(dl / 2);
  return 2 * 6371008.8 * std::asin(std::sqrt(h));
}

class MissionGatewayTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    char dir[] = "/tmp/riskplan-web-mission-XXXXXX";
    ASSERT_NE(mkdtemp(dir), nullptr);
    dir_ = new std::string(dir);
    const std::string tool = std::string(RISKPLAN_BIN_DIR) + "/riskplan-tool";
    for (const char* name : {"lux-demo", "demo-city"}) {
      const std::string out = absl::StrCat(*dir_, "/maps/", name);
      ASSERT_EQ(std::system(absl::StrCat(tool, " write-map --out=", out, " --size_m=2000 >/dev/null")
                                .c_str()),
                0);
      if (std::string(name) == "lux-demo") {
        std::ifstream in(out + "/manifest.json");
        Json manifest = Json::parse(in);
        manifest["name"] = name;
        manifest["geo"] = {{"origin_lat_deg", 49.6}, {"origin_lon_deg", 6.1}, {"crs", "test placement"}};
        std::ofstream(out + "/manifest.json") << manifest.dump();
      }
    }
    auto server = ServerProcess::Start({"--maps=" + *dir_ + "/maps", "--rpc_log=false"});
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = server->release();
    auto web = ServerProcess::StartWeb(server_->address(), {"--heartbeat_ms=100"});
    ASSERT_TRUE(web.ok()) << web.status();
    web_ = web->release();
    const Json maps = Json::parse(Call("GET", "/api/maps").body)["maps"];
    for (const Json& m : maps) {
      if (m["name"] == "lux-demo") {
        for (const Json& c : m["bounds_wgs84"]["corners"]) {
          corners_.push_back({c["lat_deg"].get<double>(), c["lon_deg"].get<double>()});
        }
      }
    }
    ASSERT_EQ(corners_.size(), 4u);
  }
  static void TearDownTestSuite() {
    delete web_;
    delete server_;
    web_ = server_ = nullptr;
    std::system(absl::StrCat("rm -rf ", *dir_).c_str());
    delete dir_;
  }

  static HttpResponse Call(const std::string& method, const std::string& path,
                           const std::string& body = "") {
    auto response = HttpRequest(web_->address(), method, path, body, {}, kDeadline);
    EXPECT_TRUE(response.ok()) << response.status();
    return response.ok() ? *response : HttpResponse{};
  }

  // (lat, lon) of local (x, y) on lux-demo, between its WGS84 corners
  // (south-west, south-east, north-east, north-west): centimetres off.
  static std::pair<double, double> Wgs84(double x, double y) {
    const double u = x / kSizeM, v = y / kSizeM;
    const double w[4] = {(1 - u) * (1 - v), u * (1 - v), u * v, (1 - u) * v};
    double lat = 0, lon = 0;
    for (int k = 0; k < 4; ++k) {
      lat += w[k] * corners_[k].first;
      lon += w[k] * corners_[k].second;
    }
    return {lat, lon};
  }
  static Json Item(int command, int id, double x, double y, double alt_m) {
    const auto [lat, lon] = Wgs84(x, y);
    return testing_qgc::SimpleItem(command, id, lat, lon, alt_m);
  }
  // Takeoff, a waypoint, land, inside the city; `extra` merged at the top.
  static Json ThreePointPlan(double waypoint_x = 1000.0, const Json& extra = Json::object()) {
    const auto [home_lat, home_lon] = Wgs84(300, 375);
    Json plan = testing_qgc::PlanDocument(
        home_lat, home_lon, 200,
        Json::array({Item(22, 1, 300, 375, 240), Item(16, 2, waypoint_x, 900, 250),
                     Item(21, 3, 1700, 1625, 250)}));
    for (auto it = extra.begin(); it != extra.end(); ++it) plan[it.key()] = it.value();
    return plan;
  }
  static Json Request(int64_t iterations, const Json& limits = Json()) {
    Json r = {{"map", "lux-demo"},
              {"budget", {{"iterations", std::to_string(iterations)}, {"time_ms", "0"}}},
              {"seed", "3"}};
    if (!limits.is_null()) r["limits"] = limits;
    return r;
  }
  // Starts a mission; every event of its stream.
  static std::vector<SseEvent> PlanMission(const Json& plan, const Json& request) {
    HttpResponse r = Call("POST", "/api/mission/plans",
                          Json{{"plan", plan.dump(2)}, {"request", request}}.dump());
    EXPECT_EQ(r.status, 201) << r.body;
    if (r.status != 201) return {};
    const Json started = Json::parse(r.body);
    EXPECT_EQ(started["legs"], 2);
    auto stream = SseStream::Open(web_->address(), started["events"].get<std::string>(), {},
                                  kDeadline);
    EXPECT_TRUE(stream.ok()) << stream.status();
    if (!stream.ok()) return {};
    EXPECT_TRUE((*stream)->ReadAll(kDeadline));
    return (*stream)->events();
  }
  static void ExpectRefused(const std::string& path, const std::string& body, int status,
                            const std::string& words) {
    HttpResponse r = Call("POST", path, body);
    EXPECT_EQ(r.status, status) << r.body;
    const Json j = Json::parse(r.body, nullptr, false);
    ASSERT_TRUE(j.is_object()) << r.body;
    EXPECT_EQ(j["source"], "gateway");
    EXPECT_THAT(j["message"].get<std::string>(), HasSubstr(words));
  }

  static inline std::string* dir_ = nullptr;
  static inline ServerProcess* server_ = nullptr;
  static inline ServerProcess* web_ = nullptr;
  static inline std::vector<std::pair<double, double>> corners_;
};

TEST_F(MissionGatewayTest, AnUploadedPlanIsReadForThePageWithItsLimits) {
  const Json plan = ThreePointPlan(
      1000.0, {{"riskplan", {{"limits", {{"max_flight_time_s", 400}, {"pareto", true}}}}}});
  HttpResponse r = Call("POST", "/api/mission/parse", plan.dump(2));
  ASSERT_EQ(r.status, 200) << r.body;
  const Json m = Json::parse(r.body);
  ASSERT_EQ(m["points"].size(), 3u);
  EXPECT_EQ(m["points"][0]["kind"], "takeoff");
  EXPECT_EQ(m["points"][1]["kind"], "waypoint");
  EXPECT_EQ(m["points"][1]["name"], "mission item 1 (waypoint)");
  EXPECT_EQ(m["points"][1]["heading_given"], false);
  EXPECT_EQ(m["points"][2]["kind"], "land");
  const auto [lat, lon] = Wgs84(1000, 900);
  EXPECT_DOUBLE_EQ(m["points"][1]["lat_deg"].get<double>(), lat);
  EXPECT_DOUBLE_EQ(m["points"][1]["lon_deg"].get<double>(), lon);
  EXPECT_EQ(m["points"][1]["alt_m"], 250.0);
  ASSERT_EQ(m["legs"].size(), 2u);
  EXPECT_EQ(m["legs"][1]["name"],
            "leg 2 (mission item 1 (waypoint) -> mission item 2 (land))");
  // Each leg's goal is the next leg's start, at the point's chosen heading.
  EXPECT_EQ(m["legs"][0]["goal"], m["legs"][1]["start"]);
  EXPECT_DOUBLE_EQ(m["legs"][0]["goal"]["heading_deg"].get<double>(),
                   m["points"][1]["heading_deg"].get<double>());
  EXPECT_EQ(m["limits"]["max_flight_time_s"], 400.0);
  EXPECT_EQ(m["limits"]["pareto"], true);
  // Without a riskplan section: no limits.
  r = Call("POST", "/api/mission/parse", ThreePointPlan().dump());
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_FALSE(Json::parse(r.body).contains("limits"));
}

TEST_F(MissionGatewayTest, BadPlanFilesAreRefusedNamingWhatIsWrong) {
  ExpectRefused("/api/mission/parse", "{\"fileType\": ", 400, ".plan: not JSON (at byte");
  Json loiter = ThreePointPlan();
  loiter["mission"]["items"][1]["command"] = 19;
  ExpectRefused("/api/mission/parse", loiter.dump(), 400,
                "mission item 1 (doJumpId 2): command 19 (NAV_LOITER_TIME) cannot be planned");
  Json terrain = ThreePointPlan();
  terrain["mission"]["items"][2]["frame"] = 10;
  ExpectRefused("/api/mission/parse", terrain.dump(), 400, "mission item 2");
  ExpectRefused("/api/mission/parse",
                ThreePointPlan(1000.0, {{"riskplan", {{"limits", {{"endurance", 3}}}}}}).dump(), 400,
                ".plan: 'riskplan.limits': ");
  // Bounded: a file over 2 MiB (here padded with spaces, still JSON).
  const std::string big = ThreePointPlan().dump() + std::string((size_t{2} << 20) + 1, ' ');
  ExpectRefused("/api/mission/parse", big, 400,
                "this gateway reads missions of at most 2097152 bytes");
  // The routes that start and write missions read the same way.
  ExpectRefused("/api/mission/plans", Json{{"plan", loiter.dump()}, {"request", Request(100)}}.dump(),
                400, "mission item 1 (doJumpId 2): command 19");
  ExpectRefused("/api/mission/plans", Json{{"plan", ThreePointPlan().dump()}, {"requests", 1}}.dump(),
                400, "unknown field 'requests'");
  ExpectRefused("/api/mission/plans", Json{{"request", Request(100)}}.dump(), 400,
                "'plan' is required");
  Json with_start = Request(100);
  with_start["start"] = {{"x", 1}, {"y", 1}, {"z", 250}};
  ExpectRefused("/api/mission/plans",
                Json{{"plan", ThreePointPlan().dump()}, {"request", with_start}}.dump(), 400,
                "start and goal are the mission's points");
  // A point outside the map names its item; a map without geo-reference is
  // refused naming the map.
  ExpectRefused("/api/mission/plans",
                Json{{"plan", ThreePointPlan(2600.0).dump()}, {"request", Request(100)}}.dump(), 400,
                "mission item 1 (waypoint) at (");
  Json local = Request(100);
  local["map"] = "demo-city";
  ExpectRefused("/api/mission/plans", Json{{"plan", ThreePointPlan().dump()}, {"request", local}}.dump(),
                412, "map 'demo-city' has no geo-reference");
}

TEST_F(MissionGatewayTest, AMissionIsPlannedLegByLegAndWrittenBackAsTheSameMission) {
  const Json plan = ThreePointPlan();
  const std::vector<SseEvent> events = PlanMission(plan, Request(600, {{"max_flight_time_s", 400}}));
  ASSERT_GE(events.size(), 3u);
  // Every leg's updates, leg 0 first, each leg ending with its own final
  // message; then the mission's final event.
  int leg = 0;
  size_t leg_finals = 0;
  for (size_t k = 0; k + 1 < events.size(); ++k) {
    SCOPED_TRACE(k);
    EXPECT_EQ(events[k].type, "update");
    const Json d = Json::parse(events[k].data);
    EXPECT_EQ(d["legs"], 2);
    EXPECT_GE(d["leg"].get<int>(), leg);
    leg = d["leg"].get<int>();
    if (d["update"]["final"] == true) {
      ++leg_finals;
      EXPECT_LE(d["update"]["trajectory"]["flight_time_s"].get<double>(), 400.0);
    }
  }
  EXPECT_EQ(leg, 1);
  EXPECT_EQ(leg_finals, 2u);
  ASSERT_EQ(events.back().type, "final");
  const Json end = Json::parse(events.back().data);
  const Json& t = end["update"]["trajectory"];
  const Json& ends = end["mission"]["leg_ends"];
  ASSERT_EQ(ends.size(), 2u);
  const Json& wgs84 = t["waypoints_wgs84"];
  ASSERT_EQ(wgs84.size(), t["waypoints"].size());
  EXPECT_EQ(ends[1].get<size_t>(), t["waypoints"].size() - 1);
  // From the takeoff, through the waypoint (the end of leg 1), to the landing.
  const std::pair<double, double> want[3] = {Wgs84(300, 375), Wgs84(1000, 900), Wgs84(1700, 1625)};
  const size_t at[3] = {0, ends[0].get<size_t>(), ends[1].get<size_t>()};
  for (int k = 0; k < 3; ++k) {
    const Json& p = wgs84[at[k]];
    EXPECT_LT(GroundDistanceM(p["lat_deg"], p["lon_deg"], want[k].first, want[k].second), 1.0)
        << "mission point " << k;
  }
  // The whole mission within its endurance, its totals EvaluateRisk's.
  EXPECT_LE(t["flight_time_s"].get<double>(), 400.0);
  EXPECT_GT(t["risk"].get<double>(), 0.0);

  // Written back: the mission's own items at their planned places, the
  // route between them, the limits in the riskplan section.
  Json body = {{"plan", plan.dump()},
               {"request", {{"map", "lux-demo"}, {"waypoints", {{"poses", t["waypoints"]}}}}},
               {"leg_ends", ends},
               {"limits", {{"max_flight_time_s", 400}}}};
  HttpResponse r = Call("POST", "/api/mission/export", body.dump());
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.headers["content-disposition"],
            "attachment; filename=\"riskplan-mission-lux-demo.plan\"");
  const Json written = Json::parse(r.body);
  EXPECT_EQ(written["fileType"], "Plan");
  const Json& items = written["mission"]["items"];
  ASSERT_GT(items.size(), 3u);
  EXPECT_EQ(items.front()["command"], 22);
  EXPECT_EQ(items.back()["command"], 21);
  EXPECT_EQ(written["riskplan"]["mission_items"].size(), 3u);
  EXPECT_EQ(written["riskplan"]["limits"]["max_flight_time_s"], 400.0);
  // Read again (sent as a form, as curl --data-binary sends a file: the
  // body is read as it is): the same three points and the limits.
  auto form = HttpRequest(web_->address(), "POST", "/api/mission/parse", written.dump(2),
                          {{"Content-Type", "application/x-www-form-urlencoded"}}, kDeadline);
  ASSERT_TRUE(form.ok()) << form.status();
  r = *form;
  ASSERT_EQ(r.status, 200) << r.body;
  const Json again = Json::parse(r.body);
  ASSERT_EQ(again["points"].size(), 3u);
  for (int k = 0; k < 3; ++k) {
    EXPECT_LT(GroundDistanceM(again["points"][k]["lat_deg"], again["points"][k]["lon_deg"],
                              want[k].first, want[k].second),
              1.0);
  }
  EXPECT_EQ(again["limits"]["max_flight_time_s"], 400.0);

  // Leg ends that do not fit the waypoints are refused naming the field.
  body["leg_ends"] = Json::array({0, ends[1]});
  ExpectRefused("/api/mission/export", body.dump(), 400, "leg_ends must give the index");
  body["leg_ends"] = Json::array({ends[0]});
  ExpectRefused("/api/mission/export", body.dump(), 400, "the mission has 2 legs");
}

TEST_F(MissionGatewayTest, AnEnduranceNoMissionMeetsEndsNamingTheLeg) {
  const std::vector<SseEvent> events =
      PlanMission(ThreePointPlan(), Request(600, {{"max_flight_time_s", 50}}));
  ASSERT_FALSE(events.empty());
  ASSERT_EQ(events.back().type, "final");
  const Json end = Json::parse(events.back().data);
  EXPECT_FALSE(end["update"].contains("trajectory") && !end["update"]["trajectory"].is_null() &&
               !end["update"]["trajectory"]["waypoints"].empty());
  EXPECT_EQ(end["mission"]["failed_leg"], 0);
  EXPECT_THAT(end["update"]["limits"]["note"].get<std::string>(),
              StartsWith("leg 1 (mission item 0 (takeoff) -> mission item 1 (waypoint)) cannot be "
                         "flown within the limits left to it: no trajectory within the endurance"));
}

}  // namespace
}  // namespace riskplan::testing
