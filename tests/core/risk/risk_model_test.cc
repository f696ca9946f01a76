#include "core/risk/risk_model.h"

#include <cmath>
#include <random>

#include "core/base/geometry.h"
#include "gtest/gtest.h"
#include "tests/core/test_maps.h"

namespace riskplan {
namespace {

using testing_maps::UniformMap;

// Independent re-computation of M(q) straight from the spec, with no table:
// the ballistic fall, Gaussian and sums are redone here cell by cell.
double SpecConfigurationRisk(const RiskMap& map, const ModelParams& p, const Pose& q) {
  int i = 0;
  int j = 0;
  if (!map.CellOf(q.x, q.y, &i, &j)) return std::nan("");
  const double h = q.z - map.terrain(i, j);
  const int bins = p.HeightBins();
  const int b = std::clamp(static_cast<int>(std::floor(h / p.height_bin_m + 0.5)), 1, bins);
  const double w = kTwoPi / p.heading_bins;
  int k = static_cast<int>(std::floor(q.theta / w + 0.5)) % p.heading_bins;
  if (k < 0) k += p.heading_bins;
  const BallisticImpact fall = SimulateBallisticFall(b * p.height_bin_m, p);
  const double th = k * w;
  const double t = fall.fall_time_s;
  const double sa = std::sqrt(std::pow(p.sigma_pos_m, 2) + std::pow(t * p.sigma_speed_mps, 2) +
                              std::pow(t * p.sigma_wind_mps, 2));
  const double sc = std::sqrt(std::pow(p.sigma_pos_m, 2) + std::pow(t * p.sigma_wind_mps, 2));
  const int hw =
      std::min(p.max_half_width, static_cast<int>(std::ceil(3.0 * std::max(sa, sc) / map.res())));
  const int ci =
      static_cast<int>(std::floor((q.x + fall.distance_m * std::cos(th) - map.x0()) / map.res()));
  const int cj =
      static_cast<int>(std::floor((q.y + fall.distance_m * std::sin(th) - map.y0()) / map.res()));
  // Spec version 2: a window reaching past the map leaves M undefined.
  if (ci - hw < 0 || cj - hw < 0 || ci + hw >= map.nx() || cj + hw >= map.ny()) {
    return std::nan("");
  }
  double norm = 0.0;
  double rho = 0.0;
  double shelter = 0.0;
  for (int v = -hw; v <= hw; ++v) {
    for (int u = -hw; u <= hw; ++u) {
      const double ox = u * map.res();
      const double oy = v * map.res();
      const double a = std::cos(th) * ox + std::sin(th) * oy;
      const double c = -std::sin(th) * ox + std::cos(th) * oy;
      const double g = std::exp(-0.5 * (a * a / (sa * sa) + c * c / (sc * sc)));
      norm += g;
      rho += g * map.density(ci + u, cj + v);
      shelter += g * map.shelter(ci + u, cj + v);
    }
  }
  rho /= norm;
  shelter /= norm;
  const double r = p.person_radius_m + p.uav_radius_m;
  const double area = 2.0 * r * p.person_height_m / std::tan(fall.angle_rad) + kPi * r * r;
  double pcas = 0.0;
  if (fall.energy_j > p.beta_j) {
    if (shelter <= 0.0) {
      pcas = 1.0;
    } else {
      const double e = std::pow(p.beta_j / fall.energy_j, 3.0 / shelter);
      const double kk = std::min(1.0, e);
      pcas = (1.0 - kk) / (1.0 - 2.0 * kk + std::sqrt(p.alpha_j / p.beta_j) * e);
    }
  }
  return area * pcas * rho;
}

TEST(RiskModelTest, UniformMapGivesLayerValuesForEveryConfiguration) {
  const float rho = 0.0125f;
  const float shelter = 4.5f;
  auto map = UniformMap(200, 160, 5.0, rho, shelter, 120.0f);
  ASSERT_NE(map, nullptr);
  auto model = RiskModel::Create(map, ModelParams{});
  ASSERT_TRUE(model.ok()) << model.status();
  // Every height and heading bin; positions far enough from the border that the
  // kernel (at most 31 cells) and the fall distance stay inside the map.
  for (double h = 5.0; h <= 300.0; h += 5.0) {
    for (int k = 0; k < 72; ++k) {
      const Pose q{500.0, 400.0, 120.0 + h, k * kTwoPi / 72};
      const ConfigurationRisk r = (*model)->Evaluate(q);
      ASSERT_TRUE(r.defined);
      EXPECT_NEAR(r.impact_factor, static_cast<double>(rho), 1e-14);
      EXPECT_NEAR(r.expected_shelter, static_cast<double>(shelter), 1e-13);
      EXPECT_GT(r.risk, 0.0);
    }
  }
}

TEST(RiskModelTest, MatchesIndependentSpecComputation) {
  // A map with structure: density and shelter vary per cell.
  MapHeader header;
  header.name = "structured";
  header.x0 = -300.0;
  header.y0 = 200.0;
  header.res = 5.0;
  header.nx = 120;
  header.ny = 100;
  MapLayers layers;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int n = 0; n < header.nx * header.ny; ++n) {
    layers.density.push_back(static_cast<float>(0.05 * unit(rng)));
    layers.shelter.push_back(static_cast<float>(10.0 * unit(rng)));
    layers.terrain.push_back(static_cast<float>(100.0 + 20.0 * unit(rng)));
    layers.nofly.push_back(0);
  }
  auto map = RiskMap::Create(header, layers);
  ASSERT_TRUE(map.ok()) << map.status();
  ModelParams p;
  auto model = RiskModel::Create(*map, p);
  ASSERT_TRUE(model.ok());
  int checked = 0;
  int undefined = 0;
  for (int n = 0; n < 400; ++n) {
    // Including positions near the border, where the kernel reaches outside.
    const Pose q{-300.0 + 600.0 * unit(rng), 200.0 + 500.0 * unit(rng), 125.0 + 250.0 * unit(rng),
                 kTwoPi * unit(rng)};
    const ConfigurationRisk r = (*model)->Evaluate(q);
    const double expected = SpecConfigurationRisk(**map, p, q);
    if (std::isnan(expected)) {
      EXPECT_FALSE(r.defined) << "n=" << n;
      ++undefined;
      continue;
    }
    ASSERT_TRUE(r.defined) << "n=" << n;
    EXPECT_NEAR(r.risk, expected, 1e-9 * std::max(expected, 1e-300)) << "n=" << n;
    ++checked;
  }
  // Both kinds occur on this 600 x 500 m map.
  EXPECT_GE(checked, 100);
  EXPECT_GE(undefined, 50);
  EXPECT_EQ(checked + undefined, 400);
}

TEST(RiskModelTest, OutsideAndBelowTerrainAreUndefined) {
  auto map = UniformMap(50, 50, 10.0, 0.01f, 5.0f, 100.0f);
  auto model = RiskModel::Create(map, ModelParams{});
  ASSERT_TRUE(model.ok());
  EXPECT_FALSE((*model)->Evaluate(Pose{-1.0, 10.0, 200.0, 0.0}).defined);
  EXPECT_FALSE((*model)->Evaluate(Pose{10.0, 500.0, 200.0, 0.0}).defined);
  EXPECT_FALSE((*model)->Evaluate(Pose{10.0, 10.0, 100.0, 0.0}).defined);
  EXPECT_FALSE((*model)->Evaluate(Pose{10.0, 10.0, std::nan(""), 0.0}).defined);
  EXPECT_TRUE((*model)->Evaluate(Pose{250.0, 250.0, 100.5, 0.0}).defined);
  // 10 m from the corner, inside the map but with the impact window reaching
  // past it (spec version 2).
  EXPECT_FALSE((*model)->Evaluate(Pose{10.0, 10.0, 100.5, 0.0}).defined);
}

TEST(RiskModelTest, EmptyMapHasZeroRiskAndBorderIsUnknown) {
  auto map = UniformMap(40, 40, 5.0, 0.0f, 0.0f, 0.0f);
  auto model = RiskModel::Create(map, ModelParams{});
  ASSERT_TRUE(model.ok());
  // Centre of the map: density 0, so no risk.
  const ConfigurationRisk centre = (*model)->Evaluate(Pose{100.0, 100.0, 50.0, 0.0});
  EXPECT_EQ(centre.risk, 0.0);
  EXPECT_NEAR(centre.expected_shelter, 0.0, 1e-15);
  // In a corner heading out, most of the kernel is outside: version 1 read
  // shelter 10 there; version 2 leaves M undefined.
  const ConfigurationRisk corner = (*model)->Evaluate(Pose{198.0, 198.0, 100.0, kPi / 4});
  EXPECT_FALSE(corner.defined);
  EXPECT_EQ((*model)->CheckConfiguration(Pose{198.0, 198.0, 100.0, kPi / 4}),
            ViolationKind::kImpactOutsideMap);
}

TEST(RiskModelTest, AdmissibilityKinds) {
  // Flat map at 100 m with one landing site in the middle and a no-fly cell.
  MapHeader header;
  header.name = "adm";
  header.res = 10.0;
  header.nx = 100;
  header.ny = 100;
  MapLayers layers;
  layers.density.assign(10000, 0.0f);
  layers.shelter.assign(10000, 0.0f);
  layers.terrain.assign(10000, 100.0f);
  layers.nofly.assign(10000, 0);
  layers.nofly[10 * 100 + 10] = 1;
  layers.landing_sites.push_back({"site", 50, 50});
  auto map = RiskMap::Create(header, layers);
  ASSERT_TRUE(map.ok()) << map.status();
  auto model = RiskModel::Create(*map, ModelParams{});
  ASSERT_TRUE(model.ok());
  const RiskModel& m = **model;
  double limit = 0.0;
  EXPECT_EQ(m.CheckConfiguration(Pose{505.0, 505.0, 200.0, 0.0}), ViolationKind::kNone);
  EXPECT_EQ(m.CheckConfiguration(Pose{-5.0, 505.0, 200.0, 0.0}), ViolationKind::kOutsideMap);
  EXPECT_EQ(m.CheckConfiguration(Pose{1000.0, 505.0, 200.0, 0.0}), ViolationKind::kOutsideMap);
  EXPECT_EQ(m.CheckConfiguration(Pose{105.0, 105.0, 200.0, 0.0}), ViolationKind::kNoFlyZone);
  EXPECT_EQ(m.CheckConfiguration(Pose{505.0, 505.0, 100.0, 0.0}, &limit),
            ViolationKind::kTerrainCollision);
  EXPECT_EQ(limit, 100.0);
  EXPECT_EQ(m.CheckConfiguration(Pose{505.0, 505.0, 129.0, 0.0}, &limit),
            ViolationKind::kBelowSafeAltitude);
  EXPECT_EQ(limit, 130.0);
  EXPECT_EQ(m.CheckConfiguration(Pose{505.0, 505.0, 251.0, 0.0}, &limit),
            ViolationKind::kAboveMaxAltitude);
  EXPECT_EQ(limit, 250.0);
  // 400 m from the site, a glide needs 110 + 400/10 = 150 m.
  EXPECT_EQ(m.CheckConfiguration(Pose{905.0, 505.0, 149.0, 0.0}, &limit),
            ViolationKind::kBelowSafeAltitude);
  EXPECT_NEAR(limit, 150.0, 1e-9);
  EXPECT_EQ(m.CheckConfiguration(Pose{905.0, 505.0, 150.0, 0.0}), ViolationKind::kNone);
}

TEST(RiskModelTest, OverriddenGlideParametersRecomputeTheLayer) {
  auto map = UniformMap(100, 100, 10.0, 0.0f, 0.0f, 100.0f, {{"site", 50, 50}});
  ModelParams steep;
  steep.glide_ratio = 5.0;
  auto model = RiskModel::Create(map, steep);
  ASSERT_TRUE(model.ok());
  // 400 m from the site at G = 5: 110 + 80 = 190 m.
  EXPECT_NEAR((*model)->SafeAltitude(90, 50), 190.0, 1e-9);
}

TEST(RiskModelTest, RejectsBadParameters) {
  auto map = UniformMap(10, 10, 10.0, 0.0f, 0.0f, 100.0f);
  ModelParams p;
  p.mass_kg = -1.0;
  auto model = RiskModel::Create(map, p);
  ASSERT_FALSE(model.ok());
  EXPECT_NE(model.status().message().find("mass_kg"), std::string::npos) << model.status();
  p = ModelParams{};
  p.airspeed_mps = std::nan("");
  EXPECT_FALSE(RiskModel::Create(map, p).ok());
}

}  // namespace
}  // namespace riskplan
