#include "core/map/risk_map.h"

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "core/map/demo_city.h"

namespace riskplan {
namespace {

using ::testing::HasSubstr;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kSqrt2 = std::numbers::sqrt2;

struct Raw {
  MapHeader header;
  MapLayers layers;
};

// A flat map: density 0.001, shelter 5, terrain `terrain_m`, no no-fly cells,
// no landing sites.
Raw Flat(int nx, int ny, double res = 10.0, float terrain_m = 100.0f) {
  Raw raw;
  raw.header.name = "test-map";
  raw.header.res = res;
  raw.header.nx = nx;
  raw.header.ny = ny;
  const size_t n = static_cast<size_t>(nx) * ny;
  raw.layers.density.assign(n, 0.001f);
  raw.layers.shelter.assign(n, 5.0f);
  raw.layers.terrain.assign(n, terrain_m);
  raw.layers.nofly.assign(n, 0);
  return raw;
}

std::shared_ptr<const RiskMap> MustCreate(Raw raw, double glide_ratio = 10.0,
                                          double clearance_m = 10.0) {
  auto map =
      RiskMap::Create(std::move(raw.header), std::move(raw.layers), glide_ratio, clearance_m);
  EXPECT_TRUE(map.ok()) << map.status();
  return map.ok() ? *map : nullptr;
}

std::string CreateError(Raw raw, double glide_ratio = 10.0, double clearance_m = 10.0) {
  auto map =
      RiskMap::Create(std::move(raw.header), std::move(raw.layers), glide_ratio, clearance_m);
  EXPECT_FALSE(map.ok());
  if (map.ok()) return "";
  EXPECT_EQ(map.status().code(), absl::StatusCode::kInvalidArgument);
  return std::string(map.status().message());
}

size_t Idx(const Raw& raw, int i, int j) { return static_cast<size_t>(j) * raw.header.nx + i; }

TEST(RiskMapTest, CellOfFollowsTheSpecFormulaWithNegativeOrigin) {
  Raw raw = Flat(20, 10);
  raw.header.x0 = -100.0;
  raw.header.y0 = -50.0;
  auto map = MustCreate(std::move(raw));
  ASSERT_NE(map, nullptr);
  int i = -7, j = -7;
  ASSERT_TRUE(map->CellOf(-100.0, -50.0, &i, &j));  // south-west corner is inside
  EXPECT_EQ(i, 0);
  EXPECT_EQ(j, 0);
  ASSERT_TRUE(map->CellOf(-90.0, -40.0, &i, &j));  // a cell's west/south edges belong to it
  EXPECT_EQ(i, 1);
  EXPECT_EQ(j, 1);
  ASSERT_TRUE(map->CellOf(-0.5, -0.5, &i, &j));  // negative, so floor and not truncation
  EXPECT_EQ(i, 9);
  EXPECT_EQ(j, 4);
  ASSERT_TRUE(map->CellOf(0.0, 0.0, &i, &j));
  EXPECT_EQ(i, 10);
  EXPECT_EQ(j, 5);
  ASSERT_TRUE(map->CellOf(99.999, 49.999, &i, &j));
  EXPECT_EQ(i, 19);
  EXPECT_EQ(j, 9);

  i = j = -7;
  EXPECT_FALSE(map->CellOf(100.0, 0.0, &i, &j));  // east edge is outside
  EXPECT_FALSE(map->CellOf(0.0, 50.0, &i, &j));   // north edge is outside
  EXPECT_FALSE(map->CellOf(-100.001, 0.0, &i, &j));
  EXPECT_FALSE(map->CellOf(0.0, -50.001, &i, &j));
  EXPECT_FALSE(map->CellOf(std::nan(""), 0.0, &i, &j));
  EXPECT_FALSE(map->CellOf(0.0, kInf, &i, &j));
  EXPECT_FALSE(map->CellOf(-1e300, 1e300, &i, &j));
  EXPECT_EQ(i, -7);  // untouched on failure
  EXPECT_EQ(j, -7);
}

TEST(RiskMapTest, AccessorsReadRowMajorSouthFirst) {
  Raw raw = Flat(4, 3);
  raw.layers.density[Idx(raw, 3, 0)] = 0.25f;
  raw.layers.terrain[Idx(raw, 0, 2)] = 321.0f;
  raw.layers.nofly[Idx(raw, 1, 1)] = 1;
  auto map = MustCreate(std::move(raw));
  ASSERT_NE(map, nullptr);
  EXPECT_EQ(map->density(3, 0), 0.25f);
  EXPECT_EQ(map->terrain(0, 2), 321.0f);
  EXPECT_TRUE(map->nofly(1, 1));
  EXPECT_FALSE(map->nofly(1, 0));
  EXPECT_DOUBLE_EQ(map->width_m(), 40.0);
  EXPECT_DOUBLE_EQ(map->height_m(), 30.0);
  EXPECT_GE(map->MemoryBytes(), 4u * 3u * (3 * sizeof(float) + 1 + sizeof(double)));
}

TEST(RiskMapTest, PaddedLayersHoldOutOfMapValuesAroundTheMap) {
  Raw raw = Flat(5, 4);
  for (int j = 0; j < 4; ++j) {
    for (int i = 0; i < 5; ++i) {
      raw.layers.density[Idx(raw, i, j)] = 0.01f * (i + 10 * j);
      raw.layers.shelter[Idx(raw, i, j)] = 0.5f * i + 0.1f * j;
    }
  }
  auto map = MustCreate(raw);
  ASSERT_NE(map, nullptr);
  const int pad = RiskMap::kPad;
  EXPECT_EQ(map->padded_nx(), 5 + 2 * pad);
  EXPECT_EQ(map->padded_ny(), 4 + 2 * pad);
  for (int j = -pad; j < 4 + pad; ++j) {
    for (int i = -pad; i < 5 + pad; ++i) {
      const int64_t k = map->PaddedIndex(i, j);
      ASSERT_GE(k, 0);
      ASSERT_LT(k, int64_t{map->padded_nx()} * map->padded_ny());
      if (map->Contains(i, j)) {
        ASSERT_EQ(map->padded_density()[k], raw.layers.density[Idx(raw, i, j)]);
        ASSERT_EQ(map->padded_shelter()[k], raw.layers.shelter[Idx(raw, i, j)]);
      } else {
        ASSERT_EQ(map->padded_density()[k], 0.0f) << i << "," << j;
        ASSERT_EQ(map->padded_shelter()[k], 10.0f) << i << "," << j;
      }
    }
  }
  EXPECT_EQ(map->PaddedIndex(-pad, -pad), 0);
}

TEST(RiskMapTest, CreateRejectsBadHeaders) {
  Raw raw = Flat(3, 3);
  raw.header.name = "";
  EXPECT_EQ(CreateError(raw),
            "map header: name '' is invalid; it must be 1 to 64 characters of [a-z0-9._-]");
  raw.header.name = "Demo City";
  EXPECT_THAT(CreateError(raw), HasSubstr("name 'Demo City' is invalid"));
  raw.header.name = std::string(65, 'a');
  EXPECT_THAT(CreateError(raw), HasSubstr("is invalid"));
  raw.header.name = std::string(64, 'a');
  EXPECT_NE(MustCreate(raw), nullptr);
  raw.header.name = "a.b_c-9";
  EXPECT_NE(MustCreate(raw), nullptr);

  Raw bad = raw;
  bad.header.res = 0.0;
  EXPECT_EQ(CreateError(bad), "map header: res has value 0; res must be > 0 and finite");
  bad.header.res = std::nan("");
  EXPECT_EQ(CreateError(bad), "map header: res has value nan; res must be > 0 and finite");
  bad = raw;
  bad.header.x0 = kInf;
  EXPECT_EQ(CreateError(bad), "map header: x0 has value inf; x0 must be finite");
  bad = raw;
  bad.header.y0 = -kInf;
  EXPECT_EQ(CreateError(bad), "map header: y0 has value -inf; y0 must be finite");
  bad = raw;
  bad.header.nx = 0;
  EXPECT_EQ(CreateError(bad), "map header: nx has value 0; nx must be in [1, 65536]");
  bad = raw;
  bad.header.ny = -3;
  EXPECT_EQ(CreateError(bad), "map header: ny has value -3; ny must be in [1, 65536]");
  bad = raw;
  bad.header.nx = 65536;
  bad.header.ny = 1025;
  EXPECT_EQ(CreateError(bad), "map header: nx*ny = 67174400 cells exceeds the limit of 67108864");
}

TEST(RiskMapTest, CreateRejectsBadGlideParameters) {
  EXPECT_EQ(CreateError(Flat(3, 3), 0.0),
            "glide_ratio has value 0; glide_ratio must be > 0 and finite");
  EXPECT_EQ(CreateError(Flat(3, 3), 10.0, -1.0),
            "glide_clearance_m has value -1; glide_clearance_m must be >= 0 and finite");
}

TEST(RiskMapTest, CreateRejectsMismatchedLayerSizes) {
  Raw raw = Flat(5, 5);
  raw.layers.density.pop_back();
  EXPECT_EQ(CreateError(raw), "layer 'density' has 24 entries; expected nx*ny = 25");
  raw = Flat(5, 5);
  raw.layers.shelter.push_back(1.0f);
  EXPECT_EQ(CreateError(raw), "layer 'shelter' has 26 entries; expected nx*ny = 25");
  raw = Flat(5, 5);
  raw.layers.terrain.clear();
  EXPECT_EQ(CreateError(raw), "layer 'terrain' has 0 entries; expected nx*ny = 25");
  raw = Flat(5, 5);
  raw.layers.nofly.resize(30);
  EXPECT_EQ(CreateError(raw), "layer 'nofly' has 30 entries; expected nx*ny = 25");
}

TEST(RiskMapTest, CreateRejectsOutOfDomainCells) {
  Raw raw = Flat(6, 5);
  raw.layers.density[Idx(raw, 2, 4)] = -0.5f;
  EXPECT_EQ(CreateError(raw),
            "layer 'density': cell (2, 4) has value -0.5; density must be >= 0 and finite");
  raw = Flat(6, 5);
  raw.layers.density[Idx(raw, 5, 0)] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(CreateError(raw),
            "layer 'density': cell (5, 0) has value nan; density must be >= 0 and finite");
  raw = Flat(6, 5);
  raw.layers.density[Idx(raw, 1, 1)] = std::numeric_limits<float>::infinity();
  EXPECT_EQ(CreateError(raw),
            "layer 'density': cell (1, 1) has value inf; density must be >= 0 and finite");
  raw = Flat(6, 5);
  raw.layers.shelter[Idx(raw, 3, 2)] = 11.0f;
  EXPECT_EQ(CreateError(raw),
            "layer 'shelter': cell (3, 2) has value 11; shelter must be in [0, 10] and finite");
  raw = Flat(6, 5);
  raw.layers.shelter[Idx(raw, 0, 3)] = -0.25f;
  EXPECT_EQ(CreateError(raw),
            "layer 'shelter': cell (0, 3) has value -0.25; shelter must be in [0, 10] and finite");
  raw = Flat(6, 5);
  raw.layers.shelter[Idx(raw, 0, 0)] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THAT(CreateError(raw), HasSubstr("cell (0, 0) has value nan"));
  raw = Flat(6, 5);
  raw.layers.terrain[Idx(raw, 4, 1)] = -std::numeric_limits<float>::infinity();
  EXPECT_EQ(CreateError(raw),
            "layer 'terrain': cell (4, 1) has value -inf; terrain must be finite");
  raw = Flat(6, 5);
  raw.layers.nofly[Idx(raw, 2, 3)] = 2;
  EXPECT_EQ(CreateError(raw), "layer 'nofly': cell (2, 3) has value 2; nofly must be 0 or 1");
  raw = Flat(6, 5);
  raw.layers.landing_sites = {{"ok", 5, 4}, {"park-3", 6, 0}};
  EXPECT_EQ(
      CreateError(raw),
      "layer 'landing_sites': site 'park-3' at cell (6, 0) is outside the map of 6 x 5 cells");
  raw.layers.landing_sites = {{"south", 0, -1}};
  EXPECT_THAT(CreateError(raw), HasSubstr("site 'south' at cell (0, -1) is outside"));

  // Domain edges are accepted.
  raw = Flat(6, 5);
  raw.layers.density[0] = 0.0f;
  raw.layers.shelter[0] = 0.0f;
  raw.layers.shelter[1] = 10.0f;
  raw.layers.terrain[0] = -420.0f;
  raw.layers.nofly[0] = 1;
  EXPECT_NE(MustCreate(raw), nullptr);
}

TEST(RiskMapTest, WithoutLandingSitesSafeAltitudeIsTerrainPlusMinAgl) {
  Raw raw = Flat(4, 4);
  raw.layers.terrain[Idx(raw, 1, 2)] = 250.0f;
  auto map = MustCreate(raw);
  ASSERT_NE(map, nullptr);
  for (double g : map->glide_altitude()) EXPECT_EQ(g, kInf);
  EXPECT_DOUBLE_EQ(map->SafeAltitude(1, 2, 30.0), 280.0);
  EXPECT_DOUBLE_EQ(map->SafeAltitude(0, 0, 30.0), 130.0);
}

TEST(RiskMapTest, GlideOnFlatFiveByFiveIsDistanceOverGlideRatio) {
  Raw raw = Flat(5, 5, /*res=*/10.0, /*terrain_m=*/100.0f);
  raw.layers.landing_sites = {{"centre", 2, 2}};
  auto map = MustCreate(raw, /*glide_ratio=*/10.0, /*clearance_m=*/10.0);
  ASSERT_NE(map, nullptr);
  auto glide = [&](int i, int j) { return map->glide_altitude()[map->Index(i, j)]; };
  // Each straight step of 10 m costs 1 m, each diagonal step sqrt(2) m.
  EXPECT_DOUBLE_EQ(glide(2, 2), 110.0);
  EXPECT_DOUBLE_EQ(glide(3, 2), 111.0);
  EXPECT_DOUBLE_EQ(glide(2, 0), 112.0);
  EXPECT_DOUBLE_EQ(glide(3, 3), 110.0 + kSqrt2);
  EXPECT_DOUBLE_EQ(glide(0, 0), 110.0 + 2 * kSqrt2);
  EXPECT_DOUBLE_EQ(glide(4, 1), 110.0 + 1.0 + kSqrt2);  // one diagonal, one straight
  EXPECT_DOUBLE_EQ(glide(0, 3), 110.0 + 1.0 + kSqrt2);
  // Safe altitude: the site itself is T + min_agl when min_agl >= clearance.
  EXPECT_DOUBLE_EQ(map->SafeAltitude(2, 2, 30.0), 130.0);
  EXPECT_DOUBLE_EQ(map->SafeAltitude(0, 0, 30.0), 130.0);
  EXPECT_DOUBLE_EQ(map->SafeAltitude(0, 0, 5.0), 110.0 + 2 * kSqrt2);
}

TEST(RiskMapTest, GlideNeverGoesBelowTerrainPlusClearance) {
  Raw raw = Flat(5, 1, 10.0, 100.0f);
  raw.layers.terrain[Idx(raw, 2, 0)] = 200.0f;  // a tower-like hill between site and cell 4
  raw.layers.landing_sites = {{"west", 0, 0}};
  auto map = MustCreate(raw);
  ASSERT_NE(map, nullptr);
  const auto& g = map->glide_altitude();
  EXPECT_DOUBLE_EQ(g[0], 110.0);
  EXPECT_DOUBLE_EQ(g[1], 111.0);
  EXPECT_DOUBLE_EQ(g[2], 210.0);  // T + clearance dominates
  EXPECT_DOUBLE_EQ(g[3], 211.0);  // ... and carries on past the hill
  EXPECT_DOUBLE_EQ(g[4], 212.0);
}

TEST(RiskMapTest, NoFlyWallForcesTheGlideThroughItsGap) {
  // 9 x 5 cells, a wall of no-fly cells in column 4 with one gap at row 0.
  Raw raw = Flat(9, 5, 10.0, 100.0f);
  for (int j = 1; j < 5; ++j) raw.layers.nofly[Idx(raw, 4, j)] = 1;
  raw.layers.landing_sites = {{"nw", 0, 4}};
  auto map = MustCreate(raw);
  ASSERT_NE(map, nullptr);
  auto glide = [&](int i, int j) { return map->glide_altitude()[map->Index(i, j)]; };
  // (0,4) -> (4,0): four diagonal steps; (4,0) -> (8,4): four more. Without the
  // wall it would be eight straight steps (118 m).
  EXPECT_NEAR(glide(4, 0), 110.0 + 4 * kSqrt2, 1e-9);
  EXPECT_NEAR(glide(8, 4), 110.0 + 8 * kSqrt2, 1e-9);
  EXPECT_NEAR(glide(5, 4), 110.0 + 4 * kSqrt2 + 3.0 + 1 * kSqrt2, 1e-9);
  for (int j = 1; j < 5; ++j) EXPECT_EQ(glide(4, j), kInf);

  // Closing the gap makes the east side unreachable.
  raw.layers.nofly[Idx(raw, 4, 0)] = 1;
  map = MustCreate(raw);
  ASSERT_NE(map, nullptr);
  EXPECT_EQ(map->glide_altitude()[map->Index(8, 4)], kInf);
  EXPECT_EQ(map->SafeAltitude(8, 4, 30.0), kInf);
  EXPECT_EQ(map->SafeAltitude(5, 0, 30.0), kInf);
  EXPECT_DOUBLE_EQ(map->SafeAltitude(3, 0, 30.0), 130.0);
}

TEST(RiskMapTest, LandingSiteInNoFlyCellIsIgnored) {
  Raw raw = Flat(3, 3);
  raw.layers.nofly[Idx(raw, 1, 1)] = 1;
  raw.layers.landing_sites = {{"inside-nofly", 1, 1}};
  auto map = MustCreate(raw);
  ASSERT_NE(map, nullptr);
  for (double g : map->glide_altitude()) EXPECT_EQ(g, kInf);
  EXPECT_EQ(map->SafeAltitude(0, 0, 30.0), kInf);  // sites exist, none reachable
}

// On an irregular map, the Dijkstra result must be the fixed point of the
// recurrence of spec section 6, checked cell by cell against all neighbours.
TEST(RiskMapTest, GlideIsTheFixedPointOfTheRecurrence) {
  const int nx = 60, ny = 45;
  Raw raw = Flat(nx, ny, 5.0, 0.0f);
  uint64_t state = 12345;
  auto next = [&state]() {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) * 0x1.0p-53;
  };
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      raw.layers.terrain[Idx(raw, i, j)] = static_cast<float>(100.0 + 0.8 * i + 40.0 * next());
      raw.layers.nofly[Idx(raw, i, j)] = next() < 0.15 ? 1 : 0;
    }
  }
  raw.layers.landing_sites = {{"a", 3, 3}, {"b", 50, 40}, {"c", 30, 20}};
  for (auto& s : raw.layers.landing_sites) raw.layers.nofly[Idx(raw, s.i, s.j)] = 0;
  auto map = MustCreate(raw, 10.0, 10.0);
  ASSERT_NE(map, nullptr);
  const auto& g = map->glide_altitude();
  int finite = 0;
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const double t = map->terrain(i, j);
      const double got = g[map->Index(i, j)];
      EXPECT_GE(map->SafeAltitude(i, j, 30.0), t + 30.0);
      if (map->nofly(i, j)) {
        EXPECT_EQ(got, kInf);
        continue;
      }
      bool is_site = false;
      for (auto& s : raw.layers.landing_sites) is_site = is_site || (s.i == i && s.j == j);
      double want = is_site ? t + 10.0 : kInf;
      for (int dj = -1; dj <= 1; ++dj) {
        for (int di = -1; di <= 1; ++di) {
          if ((di == 0 && dj == 0) || !map->Contains(i + di, j + dj)) continue;
          if (map->nofly(i + di, j + dj)) continue;
          const double dist = (di != 0 && dj != 0) ? 5.0 * kSqrt2 : 5.0;
          want = std::min(want, std::max(t + 10.0, g[map->Index(i + di, j + dj)] + dist / 10.0));
        }
      }
      ASSERT_EQ(got, want) << "cell " << i << ", " << j;
      if (std::isfinite(got)) ++finite;
    }
  }
  EXPECT_GT(finite, nx * ny / 2);
  for (auto& s : raw.layers.landing_sites) {
    EXPECT_DOUBLE_EQ(g[map->Index(s.i, s.j)], map->terrain(s.i, s.j) + 10.0);
  }
}

TEST(RiskMapTest, GlideOnAFullSizeGridIsFast) {
  const int n = 1600;
  std::vector<float> terrain(static_cast<size_t>(n) * n);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) terrain[static_cast<size_t>(j) * n + i] = 100.0f + (i + j) % 37;
  }
  std::vector<uint8_t> nofly(terrain.size(), 0);
  std::vector<LandingSite> sites;
  for (int k = 0; k < 16; ++k) sites.push_back({"s", 50 + 100 * k, 1550 - 97 * k});
  const auto start = std::chrono::steady_clock::now();
  std::vector<double> g = ComputeGlideAltitude(n, n, 5.0, terrain, nofly, sites, 10.0, 10.0);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (double v : g) ASSERT_TRUE(std::isfinite(v));
  RecordProperty("glide_seconds", std::to_string(seconds));
  // Generous: the bound is for a release build on a loaded machine; a debug
  // build or a sanitizer can be several times slower.
  EXPECT_LT(seconds, 10.0);
}

// A glide layer for a request's glide parameters is stopped by the server's
// drain rather than computed to the end.
TEST(RiskMapTest, GlideLayerStopsWhenAsked) {
  const int n = 400;  // more relaxations than one poll's worth
  std::vector<float> terrain(static_cast<size_t>(n) * n, 100.0f);
  std::vector<uint8_t> nofly(terrain.size(), 0);
  const std::vector<LandingSite> sites = {{"s", 200, 200}};
  CancellationToken token;
  EXPECT_TRUE(
      ComputeGlideAltitude(n, n, 5.0, terrain, nofly, sites, 10.0, 10.0, StopCondition(&token))
          .ok());
  token.Cancel();
  absl::StatusOr<std::vector<double>> stopped =
      ComputeGlideAltitude(n, n, 5.0, terrain, nofly, sites, 10.0, 10.0, StopCondition(&token));
  EXPECT_EQ(stopped.status().code(), absl::StatusCode::kCancelled);
}

TEST(RiskMapTest, TerrainExtremesAreKept) {
  MapHeader header;
  header.name = "slope";
  header.res = 5.0;
  header.nx = 3;
  header.ny = 2;
  MapLayers layers;
  layers.density.assign(6, 0.0f);
  layers.shelter.assign(6, 1.0f);
  layers.terrain = {10.0f, -4.5f, 30.0f, 7.0f, 120.25f, 0.0f};
  layers.nofly.assign(6, 0);
  auto map = RiskMap::Create(header, layers);
  ASSERT_TRUE(map.ok()) << map.status();
  EXPECT_EQ((*map)->terrain_min_m(), -4.5);
  EXPECT_EQ((*map)->terrain_max_m(), 120.25);
}


// Closes (value 1) or opens (value 0) the cells of `map` whose centre lies
// within `radius_m` of (x, y), leaving the map's own no-fly cells closed.
void SetDisc(const RiskMap& map, double x, double y, double radius_m, uint8_t value,
             std::vector<uint8_t>* nofly) {
  for (int j = 0; j < map.ny(); ++j) {
    const double cy = map.y0() + (j + 0.5) * map.res();
    if (std::fabs(cy - y) > radius_m) continue;
    for (int i = 0; i < map.nx(); ++i) {
      const double cx = map.x0() + (i + 0.5) * map.res();
      if (std::hypot(cx - x, cy - y) > radius_m) continue;
      const size_t k = map.Index(i, j);
      (*nofly)[k] = value != 0 ? 1 : map.layers().nofly[k];
    }
  }
}

// Every cell equal, bit for bit (infinities included); names the first that is not.
::testing::AssertionResult SameLayer(const std::vector<double>& got,
                                     const std::vector<double>& want, int nx) {
  if (got.size() != want.size()) return ::testing::AssertionFailure() << "sizes differ";
  for (size_t k = 0; k < got.size(); ++k) {
    if (std::memcmp(&got[k], &want[k], sizeof(double)) != 0) {
      return ::testing::AssertionFailure()
             << "cell (" << k % nx << ", " << k / nx << "): repaired " << got[k] << ", full "
             << want[k];
    }
  }
  return ::testing::AssertionSuccess();
}

// Zones come and go on demo-city (a landing site closed and reopened, zones
// overlapping, two removed at once, back to none): after every change the
// repaired layer equals a full computation in every cell, in still air and
// in a wind, and a repair settles a small part of the map.
TEST(RiskMapTest, RepairedGlideLayerEqualsTheFullComputationBitForBit) {
  for (const bool windy : {false, true}) {
    SCOPED_TRACE(windy ? "wind" : "still air");
    // The full 8 km city in still air; a 4 km one in the wind (a test's time).
    absl::StatusOr<std::shared_ptr<const RiskMap>> made =
        MakeDemoCity({.size_m = windy ? 4000.0 : 8000.0});
    ASSERT_TRUE(made.ok()) << made.status();
    const RiskMap& map = **made;
    const GlideWind wind =
        windy ? GlideWind{.x = 5.5, .y = -3.0, .airspeed_mps = 18.0} : GlideWind{};
    const auto full = [&](const std::vector<uint8_t>& nofly) {
      return *ComputeGlideAltitude(map.nx(), map.ny(), map.res(), map.layers().terrain, nofly,
                                   map.landing_sites(), 10.0, 10.0, StopCondition(), wind);
    };
    const double s = map.width_m() / 8000.0;
    const LandingSite& site = map.landing_sites()[map.landing_sites().size() / 2];
    const double site_x = map.x0() + (site.i + 0.5) * map.res();
    const double site_y = map.y0() + (site.j + 0.5) * map.res();
    struct Disc {
      double x, y, r;
    };
    const std::vector<Disc> zones = {
        {3000 * s, 3100 * s, 150},              // 0: a zone
        {site_x, site_y, 100},                  // 1: one on a landing site
        {5000 * s, 2500 * s, 600},              // 2: a large one
        {5000 * s + 500, 2500 * s + 300, 300},  // 3: overlapping the large one
        {1500 * s, 6500 * s, 200},              // 4
    };
    // The zones active after each change.
    const std::vector<std::vector<int>> steps = {
        {0}, {0, 1}, {0, 1, 2},  // added one by one
        {1, 2},                  // the first removed
        {1, 2, 3},               // one overlapping another
        {3},                     // two removed at once
        {4},                     // one out, one in
        {},                      // none left
    };
    std::vector<uint8_t> nofly = map.layers().nofly;
    std::vector<double> glide = full(nofly);
    int64_t lost = 0;
    for (size_t k = 0; k < steps.size(); ++k) {
      SCOPED_TRACE(k);
      std::vector<uint8_t> next = map.layers().nofly;
      for (int z : steps[k]) SetDisc(map, zones[z].x, zones[z].y, zones[z].r, 1, &next);
      GlideRepairStats stats;
      ASSERT_TRUE(RepairGlideAltitude(map.nx(), map.ny(), map.res(), map.layers().terrain,
                                      map.landing_sites(), 10.0, 10.0, wind, nofly, next, &glide,
                                      StopCondition(), &stats)
                      .ok());
      ASSERT_TRUE(SameLayer(glide, full(next), map.nx()));
      EXPECT_GT(stats.closed + stats.opened, 0);
      EXPECT_LT(stats.settled, static_cast<int64_t>(glide.size()) / 4);
      lost += stats.affected;
      nofly = std::move(next);
    }
    EXPECT_EQ(nofly, map.layers().nofly);
    EXPECT_GT(lost, 0);  // some glides ran through a zone
    EXPECT_TRUE(SameLayer(glide, windy ? full(map.layers().nofly) : map.glide_altitude(), map.nx()));
  }
}

// Random closures and openings of scattered cells on a rough random map
// (many ties between predecessors, sites closed and reopened, walls): the
// repair still equals the full computation after every change.
TEST(RiskMapTest, RepairedGlideLayerEqualsTheFullComputationOnRandomChanges) {
  const int nx = 70, ny = 55;
  Raw raw = Flat(nx, ny, 5.0, 0.0f);
  uint64_t state = 777;
  auto next = [&state]() {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) * 0x1.0p-53;
  };
  for (size_t k = 0; k < raw.layers.terrain.size(); ++k) {
    // Whole metres: many equal floors, so many ties.
    raw.layers.terrain[k] = static_cast<float>(std::floor(100.0 + 30.0 * next()));
    raw.layers.nofly[k] = next() < 0.1 ? 1 : 0;
  }
  raw.layers.landing_sites = {{"a", 3, 3}, {"b", 60, 50}, {"c", 30, 20}, {"d", 69, 0}};
  auto map = MustCreate(raw, 10.0, 10.0);
  ASSERT_NE(map, nullptr);
  for (const GlideWind& wind : {GlideWind{}, GlideWind{.x = -7.0, .y = 4.0, .airspeed_mps = 12.0}}) {
    std::vector<uint8_t> nofly = raw.layers.nofly;
    std::vector<double> glide =
        *ComputeGlideAltitude(nx, ny, 5.0, raw.layers.terrain, nofly, raw.layers.landing_sites,
                              10.0, 10.0, StopCondition(), wind);
    for (int step = 0; step < 40; ++step) {
      std::vector<uint8_t> changed = nofly;
      const int flips = 1 + static_cast<int>(next() * 60);
      for (int f = 0; f < flips; ++f) {
        const size_t k = static_cast<size_t>(next() * changed.size()) % changed.size();
        changed[k] ^= 1;
      }
      if (step % 10 == 3) {  // a wall across the map with one gap
        const int i = 10 + step;
        for (int j = 0; j < ny; ++j) changed[Idx(raw, i, j)] = j == 27 ? 0 : 1;
      }
      if (step % 7 == 5) changed[Idx(raw, 30, 20)] ^= 1;  // a site closed or reopened
      ASSERT_TRUE(RepairGlideAltitude(nx, ny, 5.0, raw.layers.terrain, raw.layers.landing_sites,
                                      10.0, 10.0, wind, nofly, changed, &glide)
                      .ok());
      ASSERT_TRUE(SameLayer(glide,
                            *ComputeGlideAltitude(nx, ny, 5.0, raw.layers.terrain, changed,
                                                  raw.layers.landing_sites, 10.0, 10.0,
                                                  StopCondition(), wind),
                            nx))
          << "step " << step;
      nofly = std::move(changed);
    }
  }
}

TEST(RiskMapTest, WithNoFlySharesTheLayersAndRepairsTheGlideLayer) {
  const int nx = 40, ny = 30;
  Raw raw = Flat(nx, ny, 5.0, 50.0f);
  raw.layers.landing_sites = {{"a", 2, 2}, {"b", 35, 25}};
  auto map = MustCreate(raw, 10.0, 10.0);
  ASSERT_NE(map, nullptr);
  std::vector<uint8_t> nofly = raw.layers.nofly;
  for (int j = 5; j < 30; ++j) nofly[Idx(raw, 20, j)] = 1;  // a wall, open at the south
  absl::StatusOr<std::shared_ptr<const RiskMap>> closed = RiskMap::WithNoFly(map, nofly);
  ASSERT_TRUE(closed.ok()) << closed.status();
  const RiskMap& c = **closed;
  EXPECT_TRUE(c.SharesLayersWith(*map));
  EXPECT_EQ(c.padded_density(), map->padded_density());
  EXPECT_EQ(&c.layers(), &map->layers());
  EXPECT_TRUE(c.nofly(20, 10));
  EXPECT_FALSE(map->nofly(20, 10));
  EXPECT_EQ(c.nofly_layer(), nofly);
  EXPECT_EQ(c.glide_altitude(), ComputeGlideAltitude(nx, ny, 5.0, raw.layers.terrain, nofly,
                                                     raw.layers.landing_sites, 10.0, 10.0));
  EXPECT_GT(c.SafeAltitude(19, 28, 0.0), map->SafeAltitude(19, 28, 0.0));
  // And back: a map made from it with the base's cells is the base's layer.
  absl::StatusOr<std::shared_ptr<const RiskMap>> open =
      RiskMap::WithNoFly(*closed, raw.layers.nofly);
  ASSERT_TRUE(open.ok());
  EXPECT_EQ((*open)->glide_altitude(), map->glide_altitude());
  EXPECT_TRUE((*open)->SharesLayersWith(*map));

  nofly[Idx(raw, 3, 4)] = 2;
  EXPECT_THAT(RiskMap::WithNoFly(map, nofly).status().message(),
              HasSubstr("layer 'nofly': cell (3, 4) has value 2; nofly must be 0 or 1"));
  nofly.pop_back();
  EXPECT_THAT(RiskMap::WithNoFly(map, nofly).status().message(),
              HasSubstr("layer 'nofly' has 1199 entries; expected nx*ny = 1200"));
}

}  // namespace
}  // namespace riskplan
