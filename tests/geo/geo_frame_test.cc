#include "geo/geo_frame.h"

#include <geodesic.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace riskplan::geo {
namespace {

using ::testing::HasSubstr;

constexpr double kA = 6378137.0;               // WGS84 semi-major axis, m
constexpr double kF = 1.0 / 298.257223563;     // WGS84 flattening
constexpr double kE2 = kF * (2.0 - kF);        // first eccentricity squared
constexpr double kDeg = std::numbers::pi / 180.0;

// Radius of curvature of the meridian at latitude phi (radians).
double MeridianRadius(double phi) {
  const double s = std::sin(phi);
  return kA * (1.0 - kE2) / std::pow(1.0 - kE2 * s * s, 1.5);
}

// Radius of curvature of the prime vertical at latitude phi (radians).
double PrimeVerticalRadius(double phi) {
  const double s = std::sin(phi);
  return kA / std::sqrt(1.0 - kE2 * s * s);
}

GeoFrame Luxembourg() {
  auto f = GeoFrame::Create({49.6, 6.1, "test"}, 1000.0, -500.0);
  EXPECT_TRUE(f.ok()) << f.status();
  return *f;
}

TEST(GeoFrameTest, OriginIsTheMapPointX0Y0) {
  const GeoFrame f = Luxembourg();
  auto xy = f.ToLocal(LatLon{49.6, 6.1});
  ASSERT_TRUE(xy.ok()) << xy.status();
  EXPECT_NEAR(xy->x, 1000.0, 1e-9);
  EXPECT_NEAR(xy->y, -500.0, 1e-9);
  auto ll = f.ToWgs84(LocalXY{1000.0, -500.0});
  ASSERT_TRUE(ll.ok()) << ll.status();
  EXPECT_NEAR(ll->lat_deg, 49.6, 1e-12);
  EXPECT_NEAR(ll->lon_deg, 6.1, 1e-12);
}

// Due north of the centre the azimuthal equidistant frame measures the
// meridian arc: 1 km north is 1000 / M radians of latitude, with M taken at
// the arc's middle latitude (the midpoint rule's error is below 1e-9 m here).
TEST(GeoFrameTest, OneKilometreNorthIsTheMeridianArc) {
  const GeoFrame f = Luxembourg();
  auto ll = f.ToWgs84(LocalXY{1000.0, 500.0});
  ASSERT_TRUE(ll.ok()) << ll.status();
  const double phi0 = 49.6 * kDeg;
  double phi1 = phi0 + 1000.0 / MeridianRadius(phi0);
  for (int k = 0; k < 3; ++k) phi1 = phi0 + 1000.0 / MeridianRadius(0.5 * (phi0 + phi1));
  const double expected_lat = phi1 / kDeg;
  EXPECT_NEAR(ll->lat_deg, expected_lat, 1e-9);  // 1e-9 deg is 0.1 mm
  EXPECT_NEAR(ll->lon_deg, 6.1, 1e-12);
}

// Due east, a small step is the prime vertical's arc times cos(lat).
TEST(GeoFrameTest, OneHundredMetresEastIsThePrimeVerticalArc) {
  const GeoFrame f = Luxembourg();
  const double phi = 49.6 * kDeg;
  const double dlon_deg = 100.0 / (PrimeVerticalRadius(phi) * std::cos(phi)) / kDeg;
  auto xy = f.ToLocal(LatLon{49.6, 6.1 + dlon_deg});
  ASSERT_TRUE(xy.ok()) << xy.status();
  EXPECT_NEAR(xy->x, 1100.0, 1e-3);
  // The parallel curves north of the great circle heading east: it leaves
  // the east axis by about d^2 tan(phi) / (2 N), 0.9 mm at 100 m.
  EXPECT_NEAR(xy->y, -500.0 + 100.0 * 100.0 * std::tan(phi) / (2 * PrimeVerticalRadius(phi)),
              1e-4);
}

TEST(GeoFrameTest, RoundTripsACityToTheMillimetre) {
  const GeoFrame f = Luxembourg();
  std::vector<LocalXY> pts;
  for (double x = -8000; x <= 8000; x += 1600) {
    for (double y = -8000; y <= 8000; y += 1600) pts.push_back({1000.0 + x, -500.0 + y});
  }
  auto ll = f.ToWgs84(pts);
  ASSERT_TRUE(ll.ok()) << ll.status();
  auto back = f.ToLocal(*ll);
  ASSERT_TRUE(back.ok()) << back.status();
  for (size_t k = 0; k < pts.size(); ++k) {
    EXPECT_NEAR((*back)[k].x, pts[k].x, 1e-6) << k;
    EXPECT_NEAR((*back)[k].y, pts[k].y, 1e-6) << k;
  }
}

TEST(GeoFrameTest, RefusesBadOriginsAndPointsNamingThem) {
  EXPECT_EQ(GeoFrame::Create({91.0, 0.0, ""}, 0, 0).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(GeoFrame::Create({0.0, 180.5, ""}, 0, 0).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(GeoFrame::Create({0.0, 0.0, ""}, NAN, 0).status().code(),
            absl::StatusCode::kInvalidArgument);
  const GeoFrame f = Luxembourg();
  auto bad = f.ToLocal(std::vector<LatLon>{{49.6, 6.1}, {95.0, 6.1}});
  ASSERT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(bad.status().message(), HasSubstr("point 1"));
  auto far = f.ToLocal(LatLon{-49.6, -173.9});  // the antipode
  ASSERT_EQ(far.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(far.status().message(), HasSubstr("1000 km"));
  auto nan = f.ToWgs84(LocalXY{NAN, 0.0});
  EXPECT_EQ(nan.status().code(), absl::StatusCode::kInvalidArgument);
}

// At the origin the local axes are east and north: a heading of 0 (north)
// is theta = pi/2, 90 (east) is 0, and so on round the compass.
TEST(GeoFrameTest, HeadingsAtTheOriginAreTheCompass) {
  const GeoFrame f = Luxembourg();
  const std::vector<GeoPose> in = {{49.6, 6.1, 300.0, 0.0},   {49.6, 6.1, 300.0, 90.0},
                                   {49.6, 6.1, 300.0, 180.0}, {49.6, 6.1, 300.0, 270.0},
                                   {49.6, 6.1, 300.0, -45.0}, {49.6, 6.1, 300.0, 765.0}};
  auto local = f.ToLocal(in);
  ASSERT_TRUE(local.ok()) << local.status();
  const double expected[] = {kPi / 2, 0.0, 3 * kPi / 2, kPi, 3 * kPi / 4, kPi / 4};
  for (size_t k = 0; k < in.size(); ++k) {
    EXPECT_NEAR((*local)[k].x, 1000.0, 1e-9) << k;
    EXPECT_NEAR((*local)[k].y, -500.0, 1e-9) << k;
    EXPECT_EQ((*local)[k].z, 300.0) << k;
    // Normalised into [0, 2 pi); north-east (-45 = 315 deg) is 3 pi / 4.
    EXPECT_NEAR(std::remainder((*local)[k].theta - expected[k], 2 * kPi), 0.0, 1e-9) << k;
    EXPECT_GE((*local)[k].theta, 0.0);
    EXPECT_LT((*local)[k].theta, 2 * kPi);
  }
}

// Away from the origin's meridian the local y axis is not true north: theta
// = pi/2 - psi + gamma, gamma PROJ's grid convergence, up to the projection's
// angular distortion (below 1e-6 rad across a city). gamma is positive east
// of the origin in the northern hemisphere and about dlon * sin(lat0).
TEST(GeoFrameTest, HeadingsFollowTheGridConvergence) {
  const GeoFrame f = Luxembourg();
  for (double x : {-8000.0, 0.0, 4000.0, 9000.0}) {
    for (double y : {-6000.0, 0.0, 8000.0}) {
      const LocalXY p{1000.0 + x, -500.0 + y};
      auto gamma = f.GridConvergenceRad(p);
      ASSERT_TRUE(gamma.ok()) << gamma.status();
      auto ll = f.ToWgs84(p);
      ASSERT_TRUE(ll.ok());
      const double approx = (ll->lon_deg - 6.1) * kDeg * std::sin(49.6 * kDeg);
      EXPECT_NEAR(*gamma, approx, 0.02 * std::fabs(approx) + 1e-9) << x << ", " << y;
      if (x > 0) {
        EXPECT_GT(*gamma, 0.0);
      } else if (x < 0) {
        EXPECT_LT(*gamma, 0.0);
      }
      for (double psi : {0.0, 37.0, 90.0, 200.0, 359.5}) {
        auto local = f.ToLocal(std::vector<GeoPose>{{ll->lat_deg, ll->lon_deg, 250.0, psi}});
        ASSERT_TRUE(local.ok()) << local.status();
        const double expected = kPi / 2 - psi * kDeg + *gamma;
        EXPECT_NEAR(std::remainder((*local)[0].theta - expected, 2 * kPi), 0.0, 1e-6)
            << x << ", " << y << ", " << psi;
      }
    }
  }
}

// An independent check of the direction: the geodesic from a pose to a point
// 5 m ahead of it in the local frame leaves at the pose's geographic heading
// (PROJ's geodesic routines, Karney's algorithm, not the projection).
TEST(GeoFrameTest, GeographicHeadingIsTheGeodesicAzimuth) {
  const GeoFrame f = Luxembourg();
  geod_geodesic g;
  geod_init(&g, 6378137.0, 1.0 / 298.257223563);
  for (double theta : {0.0, 0.4, 1.9, 3.3, 5.0}) {
    const Pose p{1000.0 + 7000.0, -500.0 + 6500.0, 410.0, theta};
    const Pose q{p.x + 5.0 * std::cos(theta), p.y + 5.0 * std::sin(theta), 410.0, theta};
    auto geo = f.ToWgs84(std::vector<Pose>{p, q});
    ASSERT_TRUE(geo.ok()) << geo.status();
    double s12 = 0, azi1 = 0, azi2 = 0;
    geod_inverse(&g, (*geo)[0].lat_deg, (*geo)[0].lon_deg, (*geo)[1].lat_deg, (*geo)[1].lon_deg,
                 &s12, &azi1, &azi2);
    // The projection's scale across the radius is 1 + s^2 / (6 R^2): 3.7e-7
    // here, 9.5 km from the origin.
    EXPECT_NEAR(s12, 5.0, 5.0 * 1e-6);
    EXPECT_NEAR(std::remainder((*geo)[0].heading_deg - azi1, 360.0), 0.0, 1e-4) << theta;
    EXPECT_EQ((*geo)[0].alt_m, 410.0);
    EXPECT_GE((*geo)[0].heading_deg, 0.0);
    EXPECT_LT((*geo)[0].heading_deg, 360.0);
  }
}

TEST(GeoFrameTest, PosesRoundTripWithTheirHeadings) {
  const GeoFrame f = Luxembourg();
  std::vector<Pose> poses;
  for (double x = -8000; x <= 8000; x += 4000) {
    for (double y = -8000; y <= 8000; y += 4000) {
      poses.push_back({1000.0 + x, -500.0 + y, 200.0 + x / 100.0, NormalizeHeading(x + y)});
    }
  }
  auto geo = f.ToWgs84(poses);
  ASSERT_TRUE(geo.ok()) << geo.status();
  auto back = f.ToLocal(*geo);
  ASSERT_TRUE(back.ok()) << back.status();
  for (size_t k = 0; k < poses.size(); ++k) {
    EXPECT_NEAR((*back)[k].x, poses[k].x, 1e-6) << k;
    EXPECT_NEAR((*back)[k].y, poses[k].y, 1e-6) << k;
    EXPECT_EQ((*back)[k].z, poses[k].z) << k;
    EXPECT_NEAR(std::remainder((*back)[k].theta - poses[k].theta, 2 * kPi), 0.0, 1e-9) << k;
  }
}

TEST(GeoFrameTest, RefusesPosesItCannotConvertNamingThem) {
  const GeoFrame f = Luxembourg();
  auto nan_heading = f.ToLocal(std::vector<GeoPose>{{49.6, 6.1, 300, 0}, {49.6, 6.1, 300, NAN}});
  ASSERT_EQ(nan_heading.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(nan_heading.status().message(), HasSubstr("pose 1"));
  auto pole = GeoFrame::Create({89.9, 0.0, ""}, 0, 0);
  ASSERT_TRUE(pole.ok());
  auto at_pole = pole->ToLocal(std::vector<GeoPose>{{90.0, 0.0, 300, 10}});
  ASSERT_EQ(at_pole.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(at_pole.status().message(), HasSubstr("pole"));
  auto inf_z = f.ToWgs84(std::vector<Pose>{{0, 0, INFINITY, 0}});
  EXPECT_EQ(inf_z.status().code(), absl::StatusCode::kInvalidArgument);
}

// The corners are the local corners' positions; the box holds every point of
// the edges, which are neither parallels nor meridians.
TEST(GeoFrameTest, BoundsHoldTheCornersAndTheEdges) {
  const GeoFrame f = Luxembourg();
  auto b = f.BoundsOf(1000.0, -500.0, 9000.0, 7500.0);
  ASSERT_TRUE(b.ok()) << b.status();
  const LocalXY corners[4] = {{1000, -500}, {9000, -500}, {9000, 7500}, {1000, 7500}};
  for (int k = 0; k < 4; ++k) {
    auto ll = f.ToWgs84(corners[k]);
    ASSERT_TRUE(ll.ok());
    EXPECT_DOUBLE_EQ(b->corners[k].lat_deg, ll->lat_deg) << k;
    EXPECT_DOUBLE_EQ(b->corners[k].lon_deg, ll->lon_deg) << k;
  }
  // Points between the 65 sampled on each edge: inside the box to within
  // 1e-9 deg (0.1 mm).
  bool south_edge_dips = false;
  for (double t = 0.013; t < 1.0; t += 0.0371) {
    const double x = 1000.0 + 8000.0 * t, y = -500.0 + 8000.0 * t;
    for (LocalXY p :
         {LocalXY{x, -500.0}, LocalXY{x, 7500.0}, LocalXY{1000.0, y}, LocalXY{9000.0, y}}) {
      auto ll = f.ToWgs84(p);
      ASSERT_TRUE(ll.ok());
      EXPECT_GE(ll->lat_deg, b->min_lat_deg - 1e-9);
      EXPECT_LE(ll->lat_deg, b->max_lat_deg + 1e-9);
      EXPECT_GE(ll->lon_deg, b->min_lon_deg - 1e-9);
      EXPECT_LE(ll->lon_deg, b->max_lon_deg + 1e-9);
      if (p.y == -500.0 && ll->lat_deg < 49.6) south_edge_dips = true;
    }
  }
  // The south edge leaves the origin due east along a geodesic, which runs
  // south of the parallel: the box reaches below the origin's latitude.
  EXPECT_TRUE(south_edge_dips);
  EXPECT_LT(b->min_lat_deg, 49.6);
}

TEST(GeoFrameTest, FrameOfAMapWithoutGeoReferenceIsRefused) {
  MapHeader h;
  h.name = "demo-city";
  auto f = FrameOfMap(h);
  ASSERT_EQ(f.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(f.status().message(), HasSubstr("demo-city"));
}

}  // namespace
}  // namespace riskplan::geo
