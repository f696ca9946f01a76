#include "client/trajectory_text.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_replace.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/trajectory_json_cases.h"

namespace riskplan::client {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;
using trajectory_json_cases::Case;
using trajectory_json_cases::Json;
using trajectory_json_cases::LoadTable;
using trajectory_json_cases::MakeCaseFile;
using trajectory_json_cases::Points;
using trajectory_json_cases::ReadCase;

TEST(TrajectoryTextTest, Pose) {
  absl::StatusOr<v1::Pose> pose = ParsePose(" 1200, 1500 ,250,0.785");
  ASSERT_TRUE(pose.ok()) << pose.status();
  EXPECT_EQ(pose->x(), 1200);
  EXPECT_EQ(pose->y(), 1500);
  EXPECT_EQ(pose->z(), 250);
  EXPECT_EQ(pose->theta(), 0.785);
  EXPECT_THAT(std::string(ParsePose("1,2,3").status().message()), HasSubstr("expected 4"));
  EXPECT_THAT(std::string(ParsePose("1,2,x,4").status().message()),
              HasSubstr("'x' is not a finite number"));
  EXPECT_FALSE(ParsePose("1,2,inf,4").ok());
}

TEST(TrajectoryTextTest, WaypointsAndPolyline) {
  absl::StatusOr<v1::Waypoints> w = ParseWaypoints("0,0,200,0; 100,0,200,1.5;");
  ASSERT_TRUE(w.ok()) << w.status();
  ASSERT_EQ(w->poses_size(), 2);
  EXPECT_EQ(w->poses(1).theta(), 1.5);
  absl::StatusOr<v1::Polyline> p = ParsePolyline("0,0,200; 100,0,200; 100,100,210");
  ASSERT_TRUE(p.ok());
  EXPECT_EQ(p->points_size(), 3);
  EXPECT_EQ(p->points(2).z(), 210);
  EXPECT_THAT(std::string(ParsePolyline("0,0,200").status().message()), HasSubstr("at least 2"));
  EXPECT_THAT(std::string(ParsePolyline("0,0,200; 1,nan,2").status().message()),
              HasSubstr("polyline point 1"));
}

TEST(TrajectoryTextTest, JsonFileRoundTrip) {
  v1::EvaluateRiskRequest request;
  ASSERT_TRUE(
      ParseTrajectoryJson(R"({"waypoints": [[0, 0, 200, 0], [10, 20, 30, 1]]})", &request).ok());
  ASSERT_EQ(request.waypoints().poses_size(), 2);
  EXPECT_EQ(request.waypoints().poses(1).y(), 20);
  const std::string json = WaypointsToJson(request.waypoints().poses());
  v1::EvaluateRiskRequest again;
  ASSERT_TRUE(ParseTrajectoryJson(json, &again).ok());
  EXPECT_EQ(again.waypoints().SerializeAsString(), request.waypoints().SerializeAsString());

  ASSERT_TRUE(ParseTrajectoryJson(R"({"polyline": [[0, 0, 200], [10, 20, 30]]})", &request).ok());
  EXPECT_TRUE(request.has_polyline());
  EXPECT_FALSE(request.has_waypoints());
  EXPECT_THAT(
      std::string(ParseTrajectoryJson(R"({"polyline": [[0, 0], [1, 2, 3]]})", &request).message()),
      HasSubstr("polyline[0]"));
  EXPECT_FALSE(ParseTrajectoryJson("{", &request).ok());
  EXPECT_FALSE(ParseTrajectoryJson(R"({"waypoints": [], "polyline": []})", &request).ok());
}

TEST(TrajectoryTextTest, ModelParametersByName) {
  v1::ModelParameters params;
  ASSERT_TRUE(ParseModelParameters("mass_kg=12, heading_bins=36", &params).ok());
  EXPECT_EQ(params.mass_kg(), 12);
  EXPECT_EQ(params.heading_bins(), 36);
  EXPECT_FALSE(params.has_airspeed_mps());
  EXPECT_THAT(std::string(ParseModelParameters("weight=3", &params).message()),
              HasSubstr("unknown model parameter 'weight'"));
  EXPECT_THAT(std::string(ParseModelParameters("heading_bins=3.5", &params).message()),
              HasSubstr("whole number"));
  EXPECT_TRUE(ParseModelParameters("", &params).ok());
}

// The trajectory JSON rule against the shared table of cases,
// tests/data/trajectory_json_cases.json, which riskplan-tool's reader
// (tests/core/flight/trajectory_io_test.cc) is tested against too. The table
// is read here with the same few lines as there: the client may not share
// code with core, not even in tests.

// The request's trajectory as the table writes it.
void Flatten(const v1::EvaluateRiskRequest& request, std::string* kind, Points* points) {
  points->clear();
  kind->clear();
  if (request.has_waypoints()) {
    *kind = "waypoints";
    for (const v1::Pose& p : request.waypoints().poses()) {
      points->push_back({p.x(), p.y(), p.z(), p.theta()});
    }
  } else if (request.has_polyline()) {
    *kind = "polyline";
    for (const v1::Point3& p : request.polyline().points())
      points->push_back({p.x(), p.y(), p.z()});
  }
}

// A request that already holds a trajectory (and a map), to see that a
// refused text leaves it alone and an accepted one replaces the trajectory.
v1::EvaluateRiskRequest Prefilled() {
  v1::EvaluateRiskRequest request;
  request.set_map("demo-city");
  v1::Point3* p = request.mutable_polyline()->add_points();
  p->set_x(-7);
  p->set_y(-8);
  p->set_z(-9);
  return request;
}

void ExpectOutcome(const Case& c, const absl::Status& status,
                   const v1::EvaluateRiskRequest& request, const std::string& path) {
  if (!c.error.empty()) {
    ASSERT_FALSE(status.ok()) << "accepted; expected: " << c.error;
    EXPECT_EQ(absl::StatusCodeToString(status.code()), c.code) << status;
    EXPECT_THAT(std::string(status.message()),
                HasSubstr(absl::StrReplaceAll(c.error, {{"{path}", path}})));
    EXPECT_EQ(request.SerializeAsString(), Prefilled().SerializeAsString())
        << "a refused trajectory changed the request";
    return;
  }
  ASSERT_TRUE(status.ok()) << status;
  std::string kind;
  Points points;
  Flatten(request, &kind, &points);
  EXPECT_EQ(kind, c.kind);
  EXPECT_EQ(points.size(), c.points.size());
  EXPECT_TRUE(points == c.points) << "the points read differ from the table's";
  EXPECT_EQ(request.map(), "demo-city");
}

TEST(TrajectoryTextTest, JsonTextFollowsTheSharedTable) {
  const Json table = LoadTable();
  ASSERT_GE(table.at("cases").size(), 40u);
  for (const Json& entry : table["cases"]) {
    const Case c = ReadCase(entry);
    SCOPED_TRACE(c.name);
    v1::EvaluateRiskRequest request = Prefilled();
    const absl::Status status = ParseTrajectoryJson(c.text, &request);
    ExpectOutcome(c, status, request, "");
    if (!status.ok()) {
      EXPECT_THAT(std::string(status.message()), StartsWith("trajectory JSON: "));
    }
  }
}

TEST(TrajectoryTextTest, JsonFilesFollowTheSharedTable) {
  const Json table = LoadTable();
  ASSERT_GE(table.at("file_cases").size(), 7u);
  const std::filesystem::path dir =
      ::testing::TempDir() + "trajectory_text_test." + std::to_string(getpid());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  int n = 0;
  for (const Json& entry : table["file_cases"]) {
    const Case c = ReadCase(entry);
    SCOPED_TRACE(c.name);
    const std::string path = MakeCaseFile(dir, n++, c);
    v1::EvaluateRiskRequest request = Prefilled();
    ExpectOutcome(c, ReadTrajectoryFile(path, &request), request, path);
  }
  std::filesystem::remove_all(dir);
}

TEST(ParseWind, SpeedAtDirectionLocalOrFromTrueNorth) {
  v1::Wind wind;
  v1::GeoWind geo;
  bool is_wgs84 = true;
  ASSERT_TRUE(ParseWind("8@270", "--wind", &wind, &geo, &is_wgs84).ok());
  EXPECT_FALSE(is_wgs84);
  EXPECT_EQ(wind.from().speed_mps(), 8.0);
  EXPECT_EQ(wind.from().from_deg(), 270.0);
  EXPECT_FALSE(geo.has_from());
  // Any finite direction: the server takes it modulo 360.
  ASSERT_TRUE(ParseWind(" 4.5 @ -450 ", "--wind", &wind, &geo, &is_wgs84).ok());
  EXPECT_EQ(wind.from().speed_mps(), 4.5);
  EXPECT_EQ(wind.from().from_deg(), -450.0);
  ASSERT_TRUE(ParseWind("wgs84:6@10", "--wind", &wind, &geo, &is_wgs84).ok());
  EXPECT_TRUE(is_wgs84);
  EXPECT_EQ(geo.from().speed_mps(), 6.0);
  EXPECT_EQ(geo.from().from_deg(), 10.0);
}

TEST(ParseWind, BadFormsAreRefusedNamingTheFlagAndWhy) {
  v1::Wind wind;
  v1::GeoWind geo;
  bool is_wgs84 = false;
  for (const auto& [text, why] : std::vector<std::pair<std::string, std::string>>{
           {"8", "it needs one '@' between the speed and the direction"},
           {"8@270@3", "it needs one '@'"},
           {"@270", "the speed '' is not a finite number"},
           {"fast@270", "the speed 'fast' is not a finite number"},
           {"nan@270", "the speed 'nan' is not a finite number"},
           {"inf@270", "the speed 'inf' is not a finite number"},
           {"-2@270", "the speed -2 is negative"},
           {"8@", "the direction '' is not a finite number"},
           {"8@west", "the direction 'west' is not a finite number"},
           {"8@inf", "the direction 'inf' is not a finite number"},
           {"wgs84:8", "it needs one '@'"}}) {
    const absl::Status s = ParseWind(text, "--wind", &wind, &geo, &is_wgs84);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << text;
    EXPECT_THAT(s.message(), HasSubstr("--wind='" + text + "' is not ")) << text;
    EXPECT_THAT(s.message(), HasSubstr("SPEED@FROM_DEG")) << text;
    EXPECT_THAT(s.message(), HasSubstr(why)) << text;
  }
  EXPECT_FALSE(wind.has_from());  // left unchanged
}

}  // namespace
}  // namespace riskplan::client
