// Ground-station missions end to end (issue 35): a QGroundControl .plan with
// a takeoff, two waypoints and a landing, planned leg by leg by the real
// client against the real server on a geo-referenced demo-city, written back
// (--mission_out) and read again (the same mission: the same four points),
// and planned again from the written file; limits on the whole mission; bad
// files refused naming the item.
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "core/map/demo_city.h"
#include "core/map/map_bundle.h"
#include "geo/export/qgc_mission.h"
#include "geo/geo_frame.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/qgc_plan_testing.h"
#include "tests/integration/server_process.h"

namespace riskplan::testing {
namespace {

using ::testing::HasSubstr;
using Json = nlohmann::json;

constexpr double kLat0 = 49.6;
constexpr double kLon0 = 6.1;

class MissionTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    char dir[] = "/tmp/riskplan-mission-XXXXXX";
    ASSERT_NE(mkdtemp(dir), nullptr);
    dir_ = new std::string(dir);
    auto demo = MakeDemoCity(DemoCityOptions{.size_m = kSmallCitySizeM});
    ASSERT_TRUE(demo.ok()) << demo.status();
    MapHeader header = (*demo)->header();
    header.name = "lux-demo";
    header.geo = GeoReference{kLat0, kLon0, "test placement"};
    auto map = RiskMap::Create(header, (*demo)->layers());
    ASSERT_TRUE(map.ok()) << map.status();
    ASSERT_TRUE(WriteMapBundle(**map, *dir_ + "/maps/lux-demo").ok());
    auto server = ServerProcess::Start({"--maps=" + *dir_ + "/maps"});
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = server->release();
    auto frame = geo::GeoFrame::Create({kLat0, kLon0, ""}, 0.0, 0.0);
    ASSERT_TRUE(frame.ok());
    frame_ = new geo::GeoFrame(*frame);
  }
  static void TearDownTestSuite() {
    delete server_;
    server_ = nullptr;
    RunCommand("rm -rf " + *dir_);
    delete dir_;
    delete frame_;
  }
  void SetUp() override { ASSERT_NE(server_, nullptr); }

  static CommandResult Cli(const std::string& args) {
    return RunCommand(std::string(RISKPLAN_BIN_DIR) + "/riskplan " + server_->CliServerFlags() +
                      " " + args + " 2>&1");
  }
  static std::string Read(const std::string& path) {
    std::ifstream in(path);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
  }
  static void Write(const std::string& path, const std::string& text) {
    std::ofstream out(path);
    out << text;
  }
  // A SimpleItem at the WGS84 form of local (x, y), altitude AMSL (frame 0).
  static Json Item(int command, int id, double x, double y, double alt_m) {
    auto g = frame_->ToWgs84(std::vector<Pose>{Pose{x, y, alt_m, 0.0}});
    EXPECT_TRUE(g.ok());
    return testing_qgc::SimpleItem(command, id, (*g)[0].lat_deg, (*g)[0].lon_deg, alt_m);
  }
  // Takeoff, two waypoints, land, inside the 2 km city.
  static std::string FourItemPlan(double waypoint_x = 800.0) {
    Json items = Json::array({Item(22, 1, 300, 375, 240), Item(16, 2, waypoint_x, 900, 250),
                              Item(16, 3, 1300, 1100, 250), Item(21, 4, 1700, 1625, 250)});
    auto home = frame_->ToWgs84(std::vector<Pose>{Pose{300, 375, 200, 0.0}});
    EXPECT_TRUE(home.ok());
    return testing_qgc::PlanDocument((*home)[0].lat_deg, (*home)[0].lon_deg, 200, std::move(items))
        .dump(2);
  }

  static ServerProcess* server_;
  static std::string* dir_;
  static geo::GeoFrame* frame_;
};
ServerProcess* MissionTest::server_ = nullptr;
std::string* MissionTest::dir_ = nullptr;
geo::GeoFrame* MissionTest::frame_ = nullptr;

TEST_F(MissionTest, FourItemPlanIsPlannedWrittenAndReadBackAsTheSameMission) {
  const std::string in = *dir_ + "/in.plan", out = *dir_ + "/out.plan",
                    geojson = *dir_ + "/out.geojson", kml = *dir_ + "/out.kml";
  const std::string text = FourItemPlan();
  Write(in, text);
  CommandResult r = Cli("plan --map=lux-demo --mission=" + in + " --mission_out=" + out +
                        " --geojson_out=" + geojson + " --kml_out=" + kml +
                        " --budget_ms=0 --iterations=600 --seed=3 --max_flight_time_s=1000");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("4 points, 3 legs"));
  EXPECT_THAT(r.output, HasSubstr("leg 3 (mission item 2 (waypoint) -> mission item 3 (land))"));
  EXPECT_THAT(r.output, HasSubstr("limit max_flight_time_s = 1000 s"));
  EXPECT_THAT(r.output, HasSubstr("(chosen)"));
  auto original = geo::ParseQgcPlan(text);
  ASSERT_TRUE(original.ok()) << original.status();
  const std::string written = Read(out);
  auto again = geo::ParseQgcPlan(written);
  ASSERT_TRUE(again.ok()) << again.status() << "\n" << written;
  ASSERT_EQ(again->points.size(), 4u);
  for (size_t k = 0; k < 4; ++k) {
    SCOPED_TRACE(k);
    EXPECT_EQ(again->points[k].kind, original->points[k].kind);
    EXPECT_NEAR(again->points[k].lat_deg, original->points[k].lat_deg, 1e-7);
    EXPECT_NEAR(again->points[k].lon_deg, original->points[k].lon_deg, 1e-7);
    EXPECT_NEAR(again->points[k].alt_m, original->points[k].alt_m, 1e-3);
  }
  // QGroundControl's fields: items of the route between the mission's own.
  Json plan = Json::parse(written);
  EXPECT_EQ(plan["fileType"], "Plan");
  EXPECT_GT(plan["mission"]["items"].size(), 4u);
  EXPECT_EQ(plan["mission"]["cruiseSpeed"], 18.0);
  EXPECT_FALSE(Read(geojson).empty());
  EXPECT_FALSE(Read(kml).empty());
  // The written file plans again as the same four-point mission.
  r = Cli("plan --map=lux-demo --mission=" + out + " --budget_ms=0 --iterations=300 --seed=3");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("4 points, 3 legs"));
}

TEST_F(MissionTest, EnduranceOfTheWholeMissionThatNoRouteMeetsNamesTheLeg) {
  const std::string in = *dir_ + "/short.plan";
  Write(in, FourItemPlan());
  CommandResult r = Cli("plan --map=lux-demo --mission=" + in +
                        " --budget_ms=0 --iterations=300 --max_flight_time_s=20");
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_THAT(r.output, HasSubstr("leg 1 (mission item 0 (takeoff) -> mission item 1 (waypoint)) "
                                  "failed: no trajectory within the endurance"));
}

TEST_F(MissionTest, BadFilesAreRefusedNamingTheItem) {
  const std::string bad = *dir_ + "/bad.plan";
  Write(bad, "{not json");
  CommandResult r = Cli("plan --map=lux-demo --mission=" + bad);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("--mission=" + bad));
  Write(bad, R"({"fileType": "Plan", "version": 7})");
  r = Cli("plan --map=lux-demo --mission=" + bad);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("version"));
  // A waypoint 5 km east of the 2 km map.
  Write(bad, FourItemPlan(7000.0));
  r = Cli("plan --map=lux-demo --mission=" + bad + " --iterations=10");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("mission item 1 (waypoint)"));
  // An item riskplan cannot plan (a loiter).
  Json plan = Json::parse(FourItemPlan());
  plan["mission"]["items"][1]["command"] = 19;
  Write(bad, plan.dump());
  r = Cli("plan --map=lux-demo --mission=" + bad);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("mission item 1"));
  EXPECT_THAT(r.output, HasSubstr("command 19"));
}

}  // namespace
}  // namespace riskplan::testing
