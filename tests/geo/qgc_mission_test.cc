// QGroundControl missions in and out (geo/export/qgc_mission.h): a 4-item
// plan read, written back around a planned route and read again as the same
// mission; bad files refused naming the item.
#include "geo/export/qgc_mission.h"

#include <string>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "nlohmann/json.hpp"

namespace riskplan::geo {
namespace {

using ::testing::HasSubstr;

// Takeoff at home, two waypoints (one with a yaw, one relative to home, with
// a camera trigger after it), land.
const char* const kFourItems = R"({
  "fileType": "Plan", "version": 1, "groundStation": "QGroundControl",
  "mission": {
    "version": 2, "firmwareType": 12, "vehicleType": 1, "cruiseSpeed": 18, "hoverSpeed": 5,
    "plannedHomePosition": [49.61, 6.12, 300],
    "items": [
      {"type": "SimpleItem", "command": 22, "frame": 3, "doJumpId": 1, "autoContinue": true,
       "params": [15, 0, 0, null, 0, 0, 50]},
      {"type": "SimpleItem", "command": 16, "frame": 0, "doJumpId": 2, "autoContinue": true,
       "params": [0, 0, 0, 90, 49.62, 6.13, 420]},
      {"type": "SimpleItem", "command": 16, "frame": 3, "doJumpId": 3, "autoContinue": true,
       "params": [0, 0, 0, null, 49.63, 6.15, 110]},
      {"type": "SimpleItem", "command": 206, "frame": 2, "doJumpId": 4, "autoContinue": true,
       "params": [25, 0, 1, 0, 0, 0, 0]},
      {"type": "SimpleItem", "command": 21, "frame": 3, "doJumpId": 5, "autoContinue": true,
       "params": [0, 0, 0, null, 49.64, 6.16, 0]}
    ]
  },
  "geoFence": {"version": 2, "circles": [], "polygons": []},
  "rallyPoints": {"version": 2, "points": []}
})";

TEST(QgcMissionTest, ReadsTakeoffWaypointsAndLand) {
  auto m = ParseQgcPlan(kFourItems);
  ASSERT_TRUE(m.ok()) << m.status();
  EXPECT_EQ(m->home_alt_m, 300.0);
  EXPECT_EQ(m->cruise_speed_mps, 18.0);
  ASSERT_EQ(m->points.size(), 4u);
  EXPECT_EQ(m->points[0].kind, MissionPointKind::kTakeoff);
  EXPECT_EQ(m->points[0].lat_deg, 49.61);  // 0, 0: at home
  EXPECT_EQ(m->points[0].alt_m, 350.0);    // 50 m above home
  EXPECT_EQ(m->points[1].kind, MissionPointKind::kWaypoint);
  EXPECT_EQ(m->points[1].alt_m, 420.0);  // absolute
  ASSERT_TRUE(m->points[1].heading_deg.has_value());
  EXPECT_EQ(*m->points[1].heading_deg, 90.0);
  EXPECT_FALSE(m->points[2].heading_deg.has_value());  // null yaw: free
  EXPECT_EQ(m->points[2].alt_m, 410.0);
  ASSERT_EQ(m->points[2].following.size(), 1u);  // the camera trigger, passed through
  EXPECT_THAT(m->points[2].following[0], HasSubstr("206"));
  EXPECT_EQ(m->points[3].kind, MissionPointKind::kLand);
  EXPECT_EQ(m->points[3].item, 4u);
}

ExportTrajectory RouteThrough(const QgcMission& m, std::vector<size_t>* leg_ends) {
  ExportTrajectory t;
  t.map = "test";
  t.airspeed_mps = 18.0;
  // Three samples per leg: two between each pair of mission points.
  for (size_t i = 0; i < m.points.size(); ++i) {
    const MissionPoint& p = m.points[i];
    if (i > 0) {
      const MissionPoint& a = m.points[i - 1];
      for (double f : {1.0 / 3.0, 2.0 / 3.0}) {
        ExportSample s;
        s.lat_deg = a.lat_deg + f * (p.lat_deg - a.lat_deg);
        s.lon_deg = a.lon_deg + f * (p.lon_deg - a.lon_deg);
        s.alt_m = a.alt_m + f * (p.alt_m - a.alt_m);
        t.samples.push_back(s);
      }
    }
    ExportSample s;
    s.lat_deg = p.lat_deg;
    s.lon_deg = p.lon_deg;
    s.alt_m = p.alt_m;
    t.samples.push_back(s);
    if (i > 0) leg_ends->push_back(t.samples.size() - 1);
  }
  t.length_m = 1000.0;
  t.flight_time_s = 60.0;
  return t;
}

TEST(QgcMissionTest, WrittenBackAroundTheRouteAndReadAsTheSameMission) {
  auto m = ParseQgcPlan(kFourItems);
  ASSERT_TRUE(m.ok()) << m.status();
  std::vector<size_t> leg_ends;
  const ExportTrajectory route = RouteThrough(*m, &leg_ends);
  auto text = QgcMissionPlanJson(*m, route, leg_ends);
  ASSERT_TRUE(text.ok()) << text.status();
  const nlohmann::json plan = nlohmann::json::parse(*text);
  EXPECT_EQ(plan["fileType"], "Plan");
  EXPECT_EQ(plan["mission"]["cruiseSpeed"], 18.0);
  EXPECT_EQ(plan["mission"]["plannedHomePosition"][2], 300.0);
  // 4 own items, 2 route points per leg (3 legs), the camera trigger.
  const nlohmann::json& items = plan["mission"]["items"];
  ASSERT_EQ(items.size(), 4u + 6u + 1u);
  EXPECT_EQ(items[0]["command"], 22);
  EXPECT_EQ(items.back()["command"], 21);
  for (size_t k = 0; k < items.size(); ++k) EXPECT_EQ(items[k]["doJumpId"], k + 1);
  EXPECT_EQ(plan["riskplan"]["mission_items"].size(), 4u);

  auto again = ParseQgcPlan(*text);
  ASSERT_TRUE(again.ok()) << again.status();
  ASSERT_EQ(again->points.size(), m->points.size());
  for (size_t i = 0; i < m->points.size(); ++i) {
    EXPECT_EQ(again->points[i].kind, m->points[i].kind) << i;
    EXPECT_DOUBLE_EQ(again->points[i].lat_deg, m->points[i].lat_deg) << i;
    EXPECT_DOUBLE_EQ(again->points[i].lon_deg, m->points[i].lon_deg) << i;
    EXPECT_DOUBLE_EQ(again->points[i].alt_m, m->points[i].alt_m) << i;
    EXPECT_EQ(again->points[i].heading_deg, m->points[i].heading_deg) << i;
    EXPECT_EQ(again->points[i].following.size(), m->points[i].following.size()) << i;
  }
  // Written again, byte for byte the same file: a fixed point.
  std::vector<size_t> leg_ends2;
  auto text2 = QgcMissionPlanJson(*again, RouteThrough(*again, &leg_ends2), leg_ends2);
  ASSERT_TRUE(text2.ok());
  EXPECT_EQ(*text2, *text);
}

absl::Status ErrorOf(const std::string& text) { return ParseQgcPlan(text).status(); }

std::string WithItem(const std::string& item) {
  return std::string(R"({"fileType": "Plan", "version": 1, "mission": {"version": 2,
    "plannedHomePosition": [49.61, 6.12, 300], "items": [
      {"type": "SimpleItem", "command": 16, "frame": 0, "doJumpId": 1,
       "params": [0, 0, 0, null, 49.62, 6.13, 420]},
      )") + item + R"(,
      {"type": "SimpleItem", "command": 16, "frame": 0, "doJumpId": 3,
       "params": [0, 0, 0, null, 49.63, 6.14, 420]}]}})";
}

TEST(QgcMissionTest, BadFilesAreRefusedNamingWhatAndWhere) {
  EXPECT_THAT(ErrorOf("{not json").message(), HasSubstr("not JSON (at byte"));
  EXPECT_THAT(ErrorOf(R"({"fileType": "Mission", "version": 1})").message(),
              HasSubstr("'fileType' must be \"Plan\""));
  EXPECT_THAT(ErrorOf(R"({"fileType": "Plan", "version": 2})").message(),
              HasSubstr("'version' is 2"));
  EXPECT_THAT(ErrorOf(R"({"fileType": "Plan", "version": 1, "mission": {"version": 1}})")
                  .message(),
              HasSubstr("'mission.version' is 1"));
  // Unknown or unplannable items, named by index and doJumpId.
  const absl::Status loiter = ErrorOf(WithItem(
      R"({"type": "SimpleItem", "command": 19, "frame": 3, "doJumpId": 2,
          "params": [30, 0, 0, null, 49.6, 6.1, 50]})"));
  EXPECT_EQ(loiter.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(loiter.message(), HasSubstr("mission item 1 (doJumpId 2): command 19 (NAV_LOITER_TIME)"));
  EXPECT_THAT(ErrorOf(WithItem(R"({"type": "ComplexItem", "complexItemType": "survey"})"))
                  .message(),
              HasSubstr("mission item 1: complex item 'survey' cannot be planned"));
  EXPECT_THAT(ErrorOf(WithItem(R"({"type": "SimpleItem", "command": 31337, "doJumpId": 2,
                                   "frame": 0, "params": [0, 0, 0, 0, 0, 0, 0]})"))
                  .message(),
              HasSubstr("command 31337 (MAV_CMD 31337) cannot be planned"));
  EXPECT_THAT(ErrorOf(WithItem(R"({"type": "SimpleItem", "command": 16, "frame": 10,
                                   "doJumpId": 2, "params": [0, 0, 0, null, 49.6, 6.1, 50]})"))
                  .message(),
              HasSubstr("altitude frame 10 (above terrain) is not supported"));
  EXPECT_THAT(ErrorOf(WithItem(R"({"type": "SimpleItem", "command": 16, "frame": 0,
                                   "doJumpId": 2, "params": [0, 0, 0, null, 95.0, 6.1, 50]})"))
                  .message(),
              HasSubstr("mission item 1 (doJumpId 2): position (latitude 95"));
  EXPECT_THAT(ErrorOf(WithItem(R"({"type": "SimpleItem", "command": 16, "frame": 0,
                                   "doJumpId": 2, "params": [0, 0, 0]})"))
                  .message(),
              HasSubstr("'params' must be an array of 7 values"));
  EXPECT_THAT(ErrorOf(WithItem(R"({"type": "SimpleItem", "command": 22, "frame": 0,
                                   "doJumpId": 2, "params": [0, 0, 0, null, 49.6, 6.1, 50]})"))
                  .message(),
              HasSubstr("takeoff after the mission's first point"));
  // A land, then more waypoints.
  EXPECT_THAT(ErrorOf(WithItem(R"({"type": "SimpleItem", "command": 21, "frame": 0,
                                   "doJumpId": 2, "params": [0, 0, 0, null, 49.6, 6.1, 300]})"))
                  .message(),
              HasSubstr("mission item 2 (doJumpId 3): waypoint after the mission's end (item 1)"));
  // Too few points.
  EXPECT_THAT(ErrorOf(R"({"fileType": "Plan", "version": 1, "mission": {"version": 2,
    "plannedHomePosition": [49.61, 6.12, 300], "items": []}})")
                  .message(),
              HasSubstr("needs at least two"));
}

}  // namespace
}  // namespace riskplan::geo
