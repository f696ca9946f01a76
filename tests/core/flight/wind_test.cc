// Risk model version 3: the mean wind, from the wind triangle to trajectories.
// Every expected number here is derived by hand from shared/spec/risk-model.md
// (sections 0-6), not read off the code.
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "core/base/geometry.h"
#include "core/base/model_params.h"
#include "core/base/wind.h"
#include "core/flight/dubins.h"
#include "core/flight/trajectory.h"
#include "core/flight/trajectory_piece.h"
#include "core/map/risk_map.h"
#include "core/risk/impact_table.h"
#include "core/risk/risk_model.h"
#include "gtest/gtest.h"
#include "tests/core/test_maps.h"

namespace riskplan {
namespace {

constexpr double kV = 18.0;  // the default airspeed
constexpr double kW = 8.0;   // the wind

// A wind of kW from the west: it blows towards the east, w = (W, 0).
ModelParams WestWind() {
  ModelParams p;
  p.wind_speed_mps = kW;
  p.wind_from_deg = 270.0;
  return p;
}

TEST(WindTriangleTest, VectorPointsWhereTheAirMoves) {
  // Section 0: w = -W (sin phi, cos phi). From the north: (0, -W).
  const WindVector north = WindVectorOf(kW, 0.0);
  EXPECT_NEAR(north.x, 0.0, 1e-12);
  EXPECT_DOUBLE_EQ(north.y, -kW);
  // From the west (270 degrees): towards the east, (W, 0).
  const WindVector west = WindVectorOf(kW, 270.0);
  EXPECT_DOUBLE_EQ(west.x, kW);
  EXPECT_NEAR(west.y, 0.0, 1e-12);
  // Any finite direction is taken modulo 360, bit for bit.
  const WindVector a = WindVectorOf(kW, 10.0);
  const WindVector b = WindVectorOf(kW, 370.0);
  const WindVector c = WindVectorOf(kW, -350.0);
  EXPECT_EQ(a.x, b.x);
  EXPECT_EQ(a.y, b.y);
  EXPECT_EQ(a.x, c.x);
  EXPECT_EQ(a.y, c.y);
}

TEST(WindTriangleTest, GroundSpeedsAlongAgainstAndAcross) {
  const WindTriangle wind(WestWind());
  // Along the wind (track east): gs = v + W; against it (west): v - W.
  EXPECT_NEAR(wind.GroundSpeed(0.0), kV + kW, 1e-12);
  EXPECT_NEAR(wind.GroundSpeed(kPi), kV - kW, 1e-12);
  // Across it (north or south): sqrt(v^2 - W^2), the crab eats the rest.
  EXPECT_NEAR(wind.GroundSpeed(kPi / 2), std::sqrt(kV * kV - kW * kW), 1e-12);
  EXPECT_NEAR(wind.GroundSpeed(3 * kPi / 2), std::sqrt(kV * kV - kW * kW), 1e-12);
}

TEST(WindTriangleTest, AirHeadingOfANorthwardTrackInAnEastwardWind) {
  const WindTriangle wind(WestWind());
  // Track north: n = (-1, 0), w . n = -W; psi = pi/2 - asin(-W / v): the nose
  // points west of north, into the wind.
  const double psi = wind.AirHeading(kPi / 2);
  EXPECT_NEAR(psi, kPi / 2 + std::asin(kW / kV), 1e-12);
  EXPECT_GT(psi, kPi / 2);
  // Along or against the wind the nose points along the track.
  EXPECT_NEAR(wind.AirHeading(0.0), 0.0, 1e-12);
  EXPECT_NEAR(wind.AirHeading(kPi), kPi, 1e-12);
}

TEST(WindTriangleTest, StillAirIsVersionTwoBitForBit) {
  const WindTriangle calm{ModelParams{}};
  EXPECT_TRUE(calm.calm());
  for (double theta : {0.0, 0.3, 1.7, 3.9, -0.2, 7.0}) {
    EXPECT_EQ(calm.AirHeading(theta), theta);
    EXPECT_EQ(calm.GroundSpeed(theta), kV);
  }
  const ModelParams p;
  EXPECT_EQ(p.GroundTurnRadius(), p.turn_radius_m);
  EXPECT_EQ(p.GroundClimbAngle(), p.max_climb_rad);
}

TEST(WindParamsTest, BoundsAndErrorsNameTheFields) {
  ModelParams p = WestWind();
  EXPECT_TRUE(ValidateModelParams(p).ok());
  p.wind_speed_mps = 0.5 * kV;  // the bound itself
  EXPECT_TRUE(ValidateModelParams(p).ok());
  p.wind_speed_mps = 0.5 * kV + 0.01;
  absl::Status s = ValidateModelParams(p);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("'wind_speed_mps'"), std::string::npos) << s;
  EXPECT_NE(s.message().find("'airspeed_mps'"), std::string::npos) << s;
  p.wind_speed_mps = -1.0;
  s = ValidateModelParams(p);
  EXPECT_NE(s.message().find("'wind_speed_mps'"), std::string::npos) << s;
  p.wind_speed_mps = std::numeric_limits<double>::quiet_NaN();
  s = ValidateModelParams(p);
  EXPECT_NE(s.message().find("'wind_speed_mps'"), std::string::npos) << s;
  p = WestWind();
  p.wind_from_deg = std::numeric_limits<double>::infinity();
  s = ValidateModelParams(p);
  EXPECT_NE(s.message().find("'wind_from_deg'"), std::string::npos) << s;
  p.wind_from_deg = std::numeric_limits<double>::quiet_NaN();
  s = ValidateModelParams(p);
  EXPECT_NE(s.message().find("'wind_from_deg'"), std::string::npos) << s;
  p.wind_from_deg = -123456.0;  // any finite direction
  EXPECT_TRUE(ValidateModelParams(p).ok());
  p = WestWind();
  p.glide_airspeed_mps = -1.0;
  s = ValidateModelParams(p);
  EXPECT_NE(s.message().find("'glide_airspeed_mps'"), std::string::npos) << s;
  // Settable by name, like every parameter.
  ModelParams q;
  ASSERT_TRUE(SetModelParam(&q, "wind_speed_mps", 5.0).ok());
  ASSERT_TRUE(SetModelParam(&q, "wind_from_deg", 90.0).ok());
  ASSERT_TRUE(SetModelParam(&q, "glide_airspeed_mps", 15.0).ok());
  EXPECT_EQ(q.wind_speed_mps, 5.0);
  EXPECT_EQ(q.wind_from_deg, 90.0);
  EXPECT_EQ(q.GlideAirspeed(), 15.0);
  EXPECT_EQ(ModelParams{}.GlideAirspeed(), kV);  // v_g = v by default
}

TEST(WindTableTest, ImpactsAreCarriedDownwindWithTheirOwnEnergy) {
  const ModelParams still;
  const ModelParams windy = WestWind();
  auto calm_table = ImpactTable::Build(still, 5.0);
  auto wind_table = ImpactTable::Build(windy, 5.0);
  ASSERT_TRUE(calm_table.ok() && wind_table.ok());
  const int north_bins = still.heading_bins;
  const int west_bin = north_bins / 2;  // theta = pi
  for (int b : {6, 18, 30}) {           // 30, 90 and 150 m
    const BallisticImpact& fall = (*calm_table)->bin(b).fall;
    const double d = fall.distance_m;
    const double t = fall.fall_time_s;
    // Air heading east (k = 0): o = d (1, 0) + w t_f = (d + W t_f, 0).
    const ImpactKernel& east = (*wind_table)->kernel(b, 0);
    EXPECT_NEAR(east.offset_x_m, d + kW * t, 1e-9);
    EXPECT_NEAR(east.offset_y_m, 0.0, 1e-9);
    // Air heading west (k = N/2): o = (-d + W t_f, 0): the wind shortens it.
    const ImpactKernel& west = (*wind_table)->kernel(b, west_bin);
    EXPECT_NEAR(west.offset_x_m, -d + kW * t, 1e-9);
    // The downwind shift of an 8 m/s wind: W t_f (the 21-57 m for
    // 30-150 m of height).
    EXPECT_NEAR(east.offset_x_m - (*calm_table)->kernel(b, 0).offset_x_m, kW * t, 1e-9);
    // Energy over the ground: 1/2 m ((v_h +- W)^2 + v_z^2).
    const double vh = fall.v_horizontal_mps;
    const double vz = fall.v_vertical_mps;
    EXPECT_NEAR(east.energy_j, 0.5 * still.mass_kg * ((vh + kW) * (vh + kW) + vz * vz),
                1e-9 * east.energy_j);
    EXPECT_NEAR(west.energy_j, 0.5 * still.mass_kg * ((vh - kW) * (vh - kW) + vz * vz),
                1e-9 * west.energy_j);
    EXPECT_NEAR(east.impact_angle_rad, std::atan2(vz, vh + kW), 1e-12);
    EXPECT_NEAR(west.impact_angle_rad, std::atan2(vz, std::fabs(vh - kW)), 1e-12);
    EXPECT_NEAR(east.exposed_area_m2, ExposedArea(std::atan2(vz, vh + kW), still), 1e-9);
    // The dispersion and the weights do not move with the wind.
    EXPECT_EQ(east.half_width, (*calm_table)->kernel(b, 0).half_width);
  }
  // Still air: every kernel's energy and area are the height bin's, bit for bit.
  for (int b = 1; b <= (*calm_table)->height_bins(); ++b) {
    for (int k = 0; k < north_bins; ++k) {
      const ImpactKernel& kernel = (*calm_table)->kernel(b, k);
      EXPECT_EQ(kernel.energy_j, (*calm_table)->bin(b).fall.energy_j);
      EXPECT_EQ(kernel.exposed_area_m2, (*calm_table)->bin(b).exposed_area_m2);
    }
  }
}

TEST(WindTableTest, ATableInAnotherWindSharesWeightsAndEqualsABuild) {
  auto calm_table = ImpactTable::Build(ModelParams{}, 5.0);
  ASSERT_TRUE(calm_table.ok());
  const ModelParams windy = WestWind();
  auto built = ImpactTable::Build(windy, 5.0);
  auto derived = ImpactTable::InWind(**calm_table, windy);
  ASSERT_TRUE(built.ok() && derived.ok()) << derived.status();
  for (int b = 1; b <= (*built)->height_bins(); ++b) {
    for (int k = 0; k < (*built)->heading_bins(); ++k) {
      const ImpactKernel& x = (*built)->kernel(b, k);
      const ImpactKernel& y = (*derived)->kernel(b, k);
      EXPECT_EQ(x.offset_x_m, y.offset_x_m);
      EXPECT_EQ(x.offset_y_m, y.offset_y_m);
      EXPECT_EQ(x.energy_j, y.energy_j);
      EXPECT_EQ(x.exposed_area_m2, y.exposed_area_m2);
      EXPECT_EQ(y.weights, (*calm_table)->kernel(b, k).weights);  // shared, not copied
    }
  }
  ModelParams other = windy;
  other.mass_kg = 12.0;
  EXPECT_EQ(ImpactTable::InWind(**calm_table, other).status().code(),
            absl::StatusCode::kInvalidArgument);
}

// A uniform, flat map: 400 x 400 cells of 5 m, density rho, shelter S.
std::shared_ptr<const RiskMap> Uniform(std::vector<LandingSite> sites = {}) {
  return testing_maps::UniformMap(400, 400, 5.0, 1e-3f, 4.0f, 0.0f, std::move(sites));
}

// M(q) by hand for a configuration over uniform ground (I = rho and S~ = S,
// as every kernel sums to 1) at height bin b, from a fall's numbers and the
// ground-relative horizontal speed at impact.
double HandRisk(const ModelParams& p, const BallisticImpact& fall, double ground_horizontal) {
  const double energy = 0.5 * p.mass_kg * (ground_horizontal * ground_horizontal +
                                           fall.v_vertical_mps * fall.v_vertical_mps);
  const double angle = std::atan2(fall.v_vertical_mps, ground_horizontal);
  const double r = p.person_radius_m + p.uav_radius_m;
  const double area = 2.0 * r * p.person_height_m / std::tan(angle) + kPi * r * r;
  const double e = std::pow(p.beta_j / energy, 3.0 / 4.0);
  const double k = std::min(1.0, e);
  const double p_cas = (1.0 - k) / (1.0 - 2.0 * k + std::sqrt(p.alpha_j / p.beta_j) * e);
  return area * p_cas * static_cast<double>(1e-3f);  // the layer's float
}

TEST(WindRiskTest, AStraightLegUpwindAgainstDownwind) {
  const ModelParams p = WestWind();
  auto model = RiskModel::Create(Uniform(), p);
  ASSERT_TRUE(model.ok()) << model.status();
  // 1 km at 100 m above the flat ground, east (downwind) and west (upwind).
  const double z = 100.0;
  const std::vector<Point3> east = {{500.0, 1000.0, z}, {1500.0, 1000.0, z}};
  const std::vector<Point3> west = {{1500.0, 1000.0, z}, {500.0, 1000.0, z}};
  auto down = EvaluateTrajectory(**model, *PiecesFromPolyline(east));
  auto up = EvaluateTrajectory(**model, *PiecesFromPolyline(west));
  ASSERT_TRUE(down.ok() && up.ok());
  ASSERT_TRUE(down->admissible && up->admissible);
  // Section 0: gs = v + W downwind, v - W upwind; section 4: the time is
  // L / gs, 1000 / 26 s and 1000 / 10 s: 2.6 times as long upwind.
  EXPECT_NEAR(down->flight_time_s, 1000.0 / (kV + kW), 1e-9);
  EXPECT_NEAR(up->flight_time_s, 1000.0 / (kV - kW), 1e-9);
  // Sections 2-4: M differs by the impact's ground speed, v_h + W downwind
  // (air heading east) and |v_h - W| upwind (air heading west); the risk is
  //   R = lambda * M * L / gs, so
  //   R_up / R_down = (M_up / (v - W)) / (M_down / (v + W)).
  const BallisticImpact& fall = (*model)->table().bin(20).fall;  // h = 100 m
  const double m_down = HandRisk(p, fall, fall.v_horizontal_mps + kW);
  const double m_up = HandRisk(p, fall, std::fabs(fall.v_horizontal_mps - kW));
  const double lambda = p.failure_rate_per_s;
  EXPECT_NEAR(down->risk, lambda * m_down * 1000.0 / (kV + kW), 1e-9 * down->risk);
  EXPECT_NEAR(up->risk, lambda * m_up * 1000.0 / (kV - kW), 1e-9 * up->risk);
  EXPECT_NEAR(up->risk / down->risk, (m_up / (kV - kW)) / (m_down / (kV + kW)), 1e-9);
  // The exposure time dominates: the upwind leg is the riskier.
  EXPECT_GT(up->risk, down->risk);
}

TEST(WindRiskTest, StillAirHasVersionTwoTimes) {
  auto model = RiskModel::Create(Uniform(), ModelParams{});
  ASSERT_TRUE(model.ok());
  const std::vector<Point3> leg = {{500.0, 1000.0, 100.0}, {1500.0, 1000.0, 100.0}};
  auto e = EvaluateTrajectory(**model, *PiecesFromPolyline(leg));
  ASSERT_TRUE(e.ok());
  EXPECT_EQ(e->flight_time_s, FlightTimeS(e->length_m, kV));
}

TEST(WindManoeuvreTest, AUTurnGrowsAsTheSquareOfOnePlusWOverV) {
  const ModelParams still;
  const ModelParams windy = WestWind();
  const double r = still.turn_radius_m;
  const double r_w = r * (1.0 + kW / kV) * (1.0 + kW / kV);
  EXPECT_NEAR(windy.GroundTurnRadius(), r_w, 1e-12);
  // A U-turn at each one's tightest: a half circle of 2 R across.
  const Pose a{0.0, 0.0, 100.0, kPi / 2};
  const DubinsAirplanePath still_turn(a, Pose{-2.0 * r, 0.0, 100.0, 3 * kPi / 2},
                                      still.GroundTurnRadius(), still.GroundClimbAngle());
  const DubinsAirplanePath wind_turn(a, Pose{-2.0 * r_w, 0.0, 100.0, 3 * kPi / 2},
                                     windy.GroundTurnRadius(), windy.GroundClimbAngle());
  EXPECT_NEAR(still_turn.Length(), kPi * r, 1e-9);
  EXPECT_NEAR(wind_turn.Length() / still_turn.Length(), (1.0 + kW / kV) * (1.0 + kW / kV), 1e-9);
}

TEST(WindManoeuvreTest, AClimbStillAirAllowsNeedsASpiralAtGammaW) {
  const ModelParams still;
  const ModelParams windy = WestWind();
  const double gamma_w = std::atan(std::tan(still.max_climb_rad) * kV / (kV + kW));
  EXPECT_NEAR(windy.GroundClimbAngle(), gamma_w, 1e-12);
  // 400 m straight ahead climbing at 90 % of tan(gamma_max): direct in still air.
  const double run = 400.0;
  const double dz = 0.9 * run * std::tan(still.max_climb_rad);
  ASSERT_GT(dz, run * std::tan(gamma_w));  // but steeper than gamma_w allows
  const Pose a{0.0, 0.0, 100.0, 0.0};
  const Pose b{run, 0.0, 100.0 + dz, 0.0};
  const DubinsAirplanePath in_still(a, b, still.GroundTurnRadius(), still.GroundClimbAngle());
  const DubinsAirplanePath in_wind(a, b, windy.GroundTurnRadius(), windy.GroundClimbAngle());
  EXPECT_EQ(in_still.spiral_turns(), 0.0);
  EXPECT_NEAR(in_still.Length(), std::hypot(run, dz), 1e-9);
  // Refused as a straight climb in wind: the manoeuvre spirals first, and no
  // part of it is steeper than gamma_w.
  EXPECT_GE(in_wind.spiral_turns(), 1.0);
  EXPECT_LE(in_wind.ClimbAngle(), gamma_w + 1e-12);
}

// A flat map with one landing site in the middle of a strip.
struct GlideCase {
  int nx = 201;
  int ny = 21;
  double res = 10.0;
  std::vector<float> terrain = std::vector<float>(nx * ny, 0.0f);
  std::vector<uint8_t> nofly = std::vector<uint8_t>(nx * ny, 0);
  std::vector<LandingSite> sites = {LandingSite{"", 100, 10}};
  double At(const std::vector<double>& g, int i, int j) const { return g[j * nx + i]; }
};

TEST(WindGlideTest, DownwindCellsNeedMoreHeightByTheRatioOfGroundSpeeds) {
  const GlideCase c;
  const double glide_ratio = 10.0;
  const double clearance = 10.0;
  const double vg = 18.0;
  const GlideWind wind{.x = kW, .y = 0.0, .airspeed_mps = vg};  // towards the east
  auto g = ComputeGlideAltitude(c.nx, c.ny, c.res, c.terrain, c.nofly, c.sites, glide_ratio,
                                clearance, StopCondition(), wind);
  ASSERT_TRUE(g.ok());
  const double site = c.At(*g, 100, 10);
  EXPECT_EQ(site, clearance);
  for (int n : {1, 5, 40}) {
    // East of the site is downwind: its glide flies west, into the wind, at
    // v_g - W over the ground; west of it the glide has the wind behind.
    const double downwind = c.At(*g, 100 + n, 10) - site;
    const double upwind = c.At(*g, 100 - n, 10) - site;
    EXPECT_NEAR(downwind, n * c.res * vg / (glide_ratio * (vg - kW)), 1e-9);
    EXPECT_NEAR(upwind, n * c.res * vg / (glide_ratio * (vg + kW)), 1e-9);
    EXPECT_NEAR(downwind / upwind, (vg + kW) / (vg - kW), 1e-9);
  }
  // Still air through the same function: the version-2 layer, bit for bit.
  const std::vector<double> v2 = ComputeGlideAltitude(c.nx, c.ny, c.res, c.terrain, c.nofly,
                                                      c.sites, glide_ratio, clearance);
  auto calm = ComputeGlideAltitude(c.nx, c.ny, c.res, c.terrain, c.nofly, c.sites, glide_ratio,
                                   clearance, StopCondition(), GlideWind{});
  ASSERT_TRUE(calm.ok());
  EXPECT_EQ(*calm, v2);
}

TEST(WindGlideTest, NoGlideMakesHeadwayWhenTheWindIsAsFastAsTheGlide) {
  const GlideCase c;
  // v_g = W: no crab angle holds a line across the wind, and into it the
  // ground speed is 0 (section 6): nothing downwind of the site reaches it.
  const GlideWind wind{.x = kW, .y = 0.0, .airspeed_mps = kW};
  auto g = ComputeGlideAltitude(c.nx, c.ny, c.res, c.terrain, c.nofly, c.sites, 10.0, 10.0,
                                StopCondition(), wind);
  ASSERT_TRUE(g.ok());
  for (int j = 0; j < c.ny; ++j) {
    for (int i = 101; i < c.nx; ++i) EXPECT_TRUE(std::isinf(c.At(*g, i, j))) << i << "," << j;
  }
  // Upwind cells glide down to it with the wind, at 2 W over the ground.
  EXPECT_NEAR(c.At(*g, 90, 10) - 10.0, 10 * c.res * kW / (10.0 * 2.0 * kW), 1e-9);
  // v_g < W: the same, and slower still.
  const GlideWind gale{.x = kW, .y = 0.0, .airspeed_mps = 0.5 * kW};
  auto h = ComputeGlideAltitude(c.nx, c.ny, c.res, c.terrain, c.nofly, c.sites, 10.0, 10.0,
                                StopCondition(), gale);
  ASSERT_TRUE(h.ok());
  EXPECT_TRUE(std::isinf(c.At(*h, 101, 10)));
  EXPECT_TRUE(std::isinf(c.At(*h, 100, 11)));  // straight across: no crab angle holds
}

TEST(WindModelTest, ModelsInWindLocateByTheAirHeadingAndKeepTheirOwnGlideLayer) {
  const std::vector<LandingSite> sites = {LandingSite{"", 200, 200}};
  const ModelParams windy = WestWind();
  auto still = RiskModel::Create(Uniform(sites), ModelParams{});
  ASSERT_TRUE(still.ok());
  auto model = RiskModel::Create((*still)->map_ptr(), windy, (*still)->table_ptr());
  ASSERT_TRUE(model.ok()) << model.status();
  EXPECT_GT((*model)->GlideBytes(), 0u);  // the map's layer is still air's
  EXPECT_EQ((*still)->GlideBytes(), 0u);
  // A northward track crabs west of north: its kernel is the air heading's.
  const Pose q{1000.0, 1000.0, 100.0, kPi / 2};
  KernelSite site;
  ASSERT_TRUE((*model)->Locate(q, &site));
  const int expected_bin = (*model)->table().HeadingBinOf(kPi / 2 + std::asin(kW / kV));
  EXPECT_EQ(site.heading_bin, expected_bin);
  EXPECT_NE(site.heading_bin, (*model)->table().HeadingBinOf(kPi / 2));
  // The wind's table borrowed the still-air weights.
  EXPECT_EQ((*model)->table().kernel(5, 3).weights, (*still)->table().kernel(5, 3).weights);
  // Glides into the wind need more height: the safe altitude 300 m east of
  // the site (downwind) is above the one 300 m west of it.
  EXPECT_GT((*model)->SafeAltitude(260, 200), (*model)->SafeAltitude(140, 200));
  EXPECT_EQ((*still)->SafeAltitude(260, 200), (*still)->SafeAltitude(140, 200));
}

}  // namespace
}  // namespace riskplan
