// The CLI's WGS84 text forms, and what the exports take from an evaluation.
#include <cmath>
#include <string_view>

#include "client/exports.h"
#include "client/trajectory_text.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace riskplan::client {
namespace {

using ::testing::HasSubstr;

TEST(Wgs84TextTest, ThePrefixSelectsTheFrameForTheWholeText) {
  std::string_view rest;
  EXPECT_TRUE(HasWgs84Prefix("  wgs84:49.6,6.1,300,45", &rest));
  EXPECT_EQ(rest, "49.6,6.1,300,45");
  EXPECT_FALSE(HasWgs84Prefix("300,375,240,0.785", &rest));
  EXPECT_EQ(rest, "300,375,240,0.785");
  EXPECT_FALSE(HasWgs84Prefix("WGS84:1,2,3,4", &rest));  // the prefix is exact

  absl::StatusOr<v1::GeoPose> pose = ParseGeoPose("49.6, 6.1, 300, 45");
  ASSERT_TRUE(pose.ok()) << pose.status();
  EXPECT_EQ(pose->lat_deg(), 49.6);  // latitude first, as ground stations write it
  EXPECT_EQ(pose->lon_deg(), 6.1);
  EXPECT_EQ(pose->alt_m(), 300.0);
  EXPECT_EQ(pose->heading_deg(), 45.0);

  absl::StatusOr<v1::GeoWaypoints> w = ParseGeoWaypoints("49.6,6.1,300,45; 49.61,6.12,310,90;");
  ASSERT_TRUE(w.ok()) << w.status();
  ASSERT_EQ(w->poses_size(), 2);
  EXPECT_EQ(w->poses(1).lon_deg(), 6.12);
  absl::StatusOr<v1::GeoPolyline> p = ParseGeoPolyline("49.6,6.1,300; 49.61,6.12,310");
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_EQ(p->points(1).alt_m(), 310.0);
  absl::StatusOr<std::vector<v1::GeoPoint2>> o = ParseGeoPoints2("49.6,6.1; 49.61,6.12");
  ASSERT_TRUE(o.ok()) << o.status();
  EXPECT_EQ(o->size(), 2u);
  EXPECT_TRUE(ParseGeoPoints2("").ok());
}

TEST(Wgs84TextTest, MistakesAreNamed) {
  EXPECT_THAT(ParseGeoPose("49.6,6.1,300").status().message(),
              HasSubstr("WGS84 pose (lat,lon,alt,heading) '49.6,6.1,300' has 3 numbers; "
                        "expected 4"));
  EXPECT_THAT(ParseGeoWaypoints("49.6,6.1,300,45; 49.6,x,300,45").status().message(),
              HasSubstr("WGS84 waypoint 1 (lat,lon,alt,heading) '49.6,x,300,45': 'x' is not a "
                        "finite number"));
  EXPECT_THAT(ParseGeoWaypoints("49.6,6.1,300,45").status().message(), HasSubstr("at least 2"));
  EXPECT_THAT(ParseGeoPolyline("49.6,6.1,nan; 49.7,6.1,300").status().message(),
              HasSubstr("'nan' is not a finite number"));
}

TEST(ExportsTest, TheTrajectoryComesFromTheServersPath) {
  v1::EvaluateRiskResponse r;
  r.set_risk(2e-7);
  r.set_length_m(90.0);
  r.set_flight_time_s(5.0);
  r.set_risk_per_flight_hour(2e-7 * 720.0);
  r.set_airspeed_mps(18.0);
  for (int k = 0; k < 3; ++k) {
    v1::PathSample* s = r.add_path();
    s->mutable_pose()->set_x(45.0 * k);
    s->set_arc_length_m(45.0 * k);
    s->set_risk(1e-6 * k);
    s->set_defined(k != 1);
    s->set_terrain_m(100.0);
    s->mutable_wgs84()->set_lat_deg(49.6 + 1e-4 * k);
    s->mutable_wgs84()->set_lon_deg(6.1);
    s->mutable_wgs84()->set_alt_m(300.0);
    s->mutable_wgs84()->set_heading_deg(90.0);
  }
  absl::StatusOr<geo::ExportTrajectory> t = ExportTrajectoryOf(r, "lux", "test", 45.0);
  ASSERT_TRUE(t.ok()) << t.status();
  ASSERT_EQ(t->samples.size(), 3u);
  EXPECT_EQ(t->samples[2].lat_deg, 49.6002);
  EXPECT_EQ(t->samples[2].arc_length_m, 90.0);
  EXPECT_FALSE(t->samples[1].risk_defined);
  EXPECT_EQ(t->risk_per_flight_hour, 2e-7 * 720.0);
  EXPECT_EQ(t->airspeed_mps, 18.0);

  r.mutable_path(1)->clear_wgs84();  // a map without geo-reference
  absl::StatusOr<geo::ExportTrajectory> none = ExportTrajectoryOf(r, "demo-city", "test", 45.0);
  EXPECT_EQ(none.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(none.status().message(), HasSubstr("map 'demo-city' has no geo-reference"));
  r.clear_path();
  EXPECT_EQ(ExportTrajectoryOf(r, "lux", "test", 45.0).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(ExportsTest, OptionsAreCheckedBeforeAnyCall) {
  ExportFiles files;
  EXPECT_TRUE(CheckExportFiles("nonsense", &files).ok());  // nothing to write
  files.plan_out = "m.plan";
  ASSERT_TRUE(CheckExportFiles("ardupilot", &files).ok());
  EXPECT_EQ(files.plan_options.firmware_type, 3);
  EXPECT_THAT(CheckExportFiles("betaflight", &files).message(), HasSubstr("--plan_firmware"));
  files.spacing_m = 0.5;
  EXPECT_THAT(CheckExportFiles("px4", &files).message(), HasSubstr("--export_spacing_m=0.5"));
}

TEST(ExportsTest, TheTargetLevelOfSafetyVerdict) {
  EXPECT_EQ(TargetLevelOfSafetyText(2.35e-7, 612.34, 18.0, 1e-6),
            "risk per flight hour 2.35e-07 (flight time 612.3 s at 18 m/s): meets the target "
            "level of safety of 1e-06 per flight hour");
  EXPECT_THAT(TargetLevelOfSafetyText(4.2e-6, 100.0, 18.0, 1e-6),
              HasSubstr("does NOT meet the target level of safety of 1e-06 per flight hour (4.2 "
                        "times it)"));
  // Equal is met.
  EXPECT_THAT(TargetLevelOfSafetyText(1e-6, 100.0, 18.0, 1e-6), HasSubstr("meets"));
}

}  // namespace
}  // namespace riskplan::client
