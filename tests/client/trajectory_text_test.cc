#include "client/trajectory_text.h"

#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace riskplan::client {
namespace {

using ::testing::HasSubstr;

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

}  // namespace
}  // namespace riskplan::client
