// The client's mission helpers (client/mission.h): headings chosen at free
// waypoints, the whole mission's limits shared among legs, legs joined into
// one route whose leg ends QgcMissionPlanJson takes.
#include "client/mission.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "gtest/gtest.h"

namespace riskplan::client {
namespace {

geo::MissionPoint Point(geo::MissionPointKind kind, double lat, double lon, double alt,
                        size_t item) {
  geo::MissionPoint p;
  p.kind = kind;
  p.lat_deg = lat;
  p.lon_deg = lon;
  p.alt_m = alt;
  p.item = item;
  return p;
}

// North 1 km, then east 1 km, then north again: the free headings.
geo::QgcMission Square() {
  geo::QgcMission m;
  const double dlat = 1000.0 / 111195.0;
  const double dlon = dlat / std::cos(49.6 * M_PI / 180.0);
  m.points = {Point(geo::MissionPointKind::kTakeoff, 49.6, 6.1, 300, 0),
              Point(geo::MissionPointKind::kWaypoint, 49.6 + dlat, 6.1, 300, 1),
              Point(geo::MissionPointKind::kWaypoint, 49.6 + dlat, 6.1 + dlon, 300, 2),
              Point(geo::MissionPointKind::kLand, 49.6 + 2 * dlat, 6.1 + dlon, 300, 3)};
  return m;
}

TEST(MissionTest, FreeHeadingsAreTheBisectorsAndGivenOnesStay) {
  geo::QgcMission m = Square();
  std::vector<double> h = MissionHeadings(m);
  ASSERT_EQ(h.size(), 4u);
  EXPECT_NEAR(h[0], 0.0, 0.1);   // bearing out: north
  EXPECT_NEAR(h[1], 45.0, 0.1);  // north in, east out
  EXPECT_NEAR(h[2], 45.0, 0.1);  // east in, north out
  EXPECT_LT(std::min(h[3], 360.0 - h[3]), 0.1);  // bearing in: north
  m.points[1].heading_deg = -90.0;
  h = MissionHeadings(m);
  EXPECT_EQ(h[1], 270.0);
  EXPECT_EQ(MissionItemName(m.points[1]), "mission item 1 (waypoint)");
  const std::vector<MissionLeg> legs = MissionLegs(m, h);
  ASSERT_EQ(legs.size(), 3u);
  EXPECT_EQ(legs[1].from, 1u);
  EXPECT_EQ(legs[1].start.heading_deg(), 270.0);
  EXPECT_EQ(legs[2].goal.lat_deg(), m.points[3].lat_deg);
}

TEST(MissionTest, LimitsAreSharedByDistanceAndTheLastLegTakesTheRest) {
  const geo::QgcMission m = Square();
  const std::vector<MissionLeg> legs = MissionLegs(m, MissionHeadings(m));
  v1::FlightLimits whole;
  whole.set_max_flight_time_s(300);
  whole.set_max_risk(3e-6);
  whole.set_max_risk_per_flight_hour(1e-6);
  whole.set_objective(v1::MIN_TIME);
  // Three legs of 1 km each: a third each at first.
  v1::FlightLimits first = LegLimits(whole, {}, m, legs, 0);
  EXPECT_NEAR(first.max_flight_time_s(), 100.0, 0.1);
  EXPECT_NEAR(first.max_risk(), 1e-6, 1e-9);
  EXPECT_EQ(first.max_length_m(), 0.0);
  EXPECT_EQ(first.max_risk_per_flight_hour(), 1e-6);
  EXPECT_EQ(first.objective(), v1::MIN_TIME);
  // After a quick first leg the others share more.
  v1::FlightLimits second = LegLimits(whole, {.flight_time_s = 60, .length_m = 1000, .risk = 0},
                                      m, legs, 1);
  EXPECT_NEAR(second.max_flight_time_s(), 120.0, 0.1);
  v1::FlightLimits last = LegLimits(whole, {.flight_time_s = 200, .length_m = 2000, .risk = 1e-6},
                                    m, legs, 2);
  EXPECT_DOUBLE_EQ(last.max_flight_time_s(), 100.0);
  EXPECT_DOUBLE_EQ(last.max_risk(), 2e-6);
  // Used up: a limit no trajectory meets, not "no limit".
  v1::FlightLimits spent = LegLimits(whole, {.flight_time_s = 400, .length_m = 0, .risk = 0}, m,
                                     legs, 2);
  EXPECT_GT(spent.max_flight_time_s(), 0.0);
  EXPECT_LT(spent.max_flight_time_s(), 1e-300);
}

TEST(MissionTest, LegsJoinIntoOneRouteWithTheirEnds) {
  auto leg = [](double lat0, int n) {
    geo::ExportTrajectory t;
    t.map = "m";
    t.airspeed_mps = 18;
    for (int k = 0; k < n; ++k) {
      geo::ExportSample s;
      s.lat_deg = lat0 + 0.001 * k;
      s.lon_deg = 6.1;
      s.alt_m = 300;
      s.arc_length_m = 100.0 * k;
      t.samples.push_back(s);
    }
    return t;
  };
  absl::StatusOr<JoinedRoute> j = JoinLegs({leg(49.6, 3), leg(49.602, 4)});
  ASSERT_TRUE(j.ok()) << j.status();
  ASSERT_EQ(j->route.samples.size(), 6u);
  EXPECT_EQ(j->leg_end_sample, (std::vector<size_t>{2, 5}));
  EXPECT_EQ(j->route.samples[5].arc_length_m, 500.0);
  EXPECT_EQ(j->route.airspeed_mps, 18.0);
  EXPECT_FALSE(JoinLegs({}).ok());
  EXPECT_FALSE(JoinLegs({leg(49.6, 1)}).ok());
}

}  // namespace
}  // namespace riskplan::client
