#include "geo/geo_frame.h"

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

TEST(GeoFrameTest, FrameOfAMapWithoutGeoReferenceIsRefused) {
  MapHeader h;
  h.name = "demo-city";
  auto f = FrameOfMap(h);
  ASSERT_EQ(f.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(f.status().message(), HasSubstr("demo-city"));
}

}  // namespace
}  // namespace riskplan::geo
