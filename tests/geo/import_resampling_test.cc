// Resampling per layer: terrain bilinear, people conserved, classes never
// averaged.
#include <cmath>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "geo/map_importer.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/geo/geodata_fixtures.h"

namespace riskplan::geo {
namespace {

using testing::At;
using testing::FreshDir;
using ::testing::HasSubstr;
using testing::RasterSpec;
using testing::WriteRaster;

constexpr double kLat = 49.6;
constexpr double kLon = 6.1;

ImportOptions MapOptions(const std::string& terrain, double res_m) {
  ImportOptions o;
  o.name = "resampling";
  o.area.center = LatLon{kLat, kLon};
  o.area.width_m = o.area.height_m = 2000.0;
  o.area.res_m = res_m;
  o.terrain = terrain;
  return o;
}

// A flat UTM DEM around the map, for the tests of the other layers.
std::string FlatDem(const std::string& dir) {
  auto c = testing::Carry("EPSG:4326", "EPSG:32632", kLon, kLat);
  RasterSpec s;
  s.srs = "EPSG:32632";
  s.width = s.height = 100;
  s.geotransform[0] = std::floor(c->first) - 2500;
  s.geotransform[1] = 50;
  s.geotransform[3] = std::floor(c->second) + 2500;
  s.geotransform[5] = -50;
  s.values.assign(100 * 100, 300.0);
  EXPECT_TRUE(WriteRaster(dir + "/flat.tif", s).ok());
  return dir + "/flat.tif";
}

// Bilinear interpolation reproduces a plane exactly: every cell of a DEM that
// is a tilted plane in UTM holds the plane's height at the cell's centre.
TEST(ImportResamplingTest, TerrainIsBilinear) {
  const std::string dir = FreshDir("bilinear");
  auto c = testing::Carry("EPSG:4326", "EPSG:32632", kLon, kLat);
  ASSERT_TRUE(c.ok());
  RasterSpec s;
  s.srs = "EPSG:32632";
  s.width = s.height = 100;
  const double e0 = std::floor(c->first) - 2500, n0 = std::floor(c->second) + 2500;
  s.geotransform[0] = e0;
  s.geotransform[1] = 50;
  s.geotransform[3] = n0;
  s.geotransform[5] = -50;
  auto plane = [&](double e, double n) { return 300.0 + 0.02 * (e - e0) - 0.01 * (n0 - n); };
  s.type = GDT_Float64;
  s.values.resize(100 * 100);
  for (int r = 0; r < 100; ++r) {
    for (int col = 0; col < 100; ++col) {
      s.values[static_cast<size_t>(r) * 100 + col] =
          plane(e0 + (col + 0.5) * 50, n0 - (r + 0.5) * 50);
    }
  }
  ASSERT_TRUE(WriteRaster(dir + "/plane.tif", s).ok());
  auto map = ImportMap(MapOptions(dir + "/plane.tif", 10.0));
  ASSERT_TRUE(map.ok()) << map.status();
  auto frame = FrameOfMap(map->header);
  ASSERT_TRUE(frame.ok());
  double worst = 0.0;
  for (int j = 0; j < map->header.ny; j += 7) {
    for (int i = 0; i < map->header.nx; i += 7) {
      auto ll = frame->ToWgs84(LocalXY{(i + 0.5) * 10.0, (j + 0.5) * 10.0});
      auto en = testing::Carry("EPSG:4326", "EPSG:32632", ll->lon_deg, ll->lat_deg);
      worst = std::max(worst, std::abs(At(map->layers.terrain, map->header, i, j) -
                                       plane(en->first, en->second)));
    }
  }
  // The float32 layer and the warper's approximate transformer (0.05 cell):
  // a few millimetres on a 2 % slope.
  EXPECT_LT(worst, 0.02);
}

struct PopulationCase {
  const char* srs;
  double pixel;  // in the CRS's units
  double res_m;  // the map's cells
};

// People per pixel in EPSG:4326, UTM and Web Mercator, on cells finer and
// coarser than the pixels: all the people of a block well inside the map are
// in the map, to a millionth (GDAL's 'sum' gives each cell the share of every
// pixel it covers; measured: 2.2e-9 at worst), also where coarse pixels are
// warped onto blocks of cells.
TEST(ImportResamplingTest, PopulationPerCellConservesPeople) {
  const std::string dir = FreshDir("population-sum");
  const std::string dem = FlatDem(dir);
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> people(0, 120);
  for (const PopulationCase& pc :
       {PopulationCase{"EPSG:4326", 0.001, 10.0}, PopulationCase{"EPSG:4326", 0.0002, 25.0},
        PopulationCase{"EPSG:32632", 100.0, 5.0}, PopulationCase{"EPSG:32632", 10.0, 25.0},
        PopulationCase{"EPSG:3857", 150.0, 20.0}}) {
    auto c = testing::Carry("EPSG:4326", pc.srs, kLon, kLat);
    ASSERT_TRUE(c.ok());
    // Pixels covering 5 km around the centre; people only within 600 m.
    const double half = std::string(pc.srs) == "EPSG:4326" ? 0.03 : 2500.0;
    const double inner = std::string(pc.srs) == "EPSG:4326" ? 0.006 : 600.0;
    RasterSpec s;
    s.srs = pc.srs;
    s.width = s.height = static_cast<int>(std::lround(2 * half / pc.pixel));
    s.geotransform[0] = c->first - half;
    s.geotransform[1] = pc.pixel;
    s.geotransform[3] = c->second + half;
    s.geotransform[5] = -pc.pixel;
    s.values.assign(static_cast<size_t>(s.width) * s.height, 0.0);
    double total = 0.0;
    for (int r = 0; r < s.height; ++r) {
      for (int col = 0; col < s.width; ++col) {
        const double dx = (col + 0.5) * pc.pixel - half, dy = half - (r + 0.5) * pc.pixel;
        if (std::abs(dx) < inner && std::abs(dy) < inner) {
          const int n = people(rng);
          s.values[static_cast<size_t>(r) * s.width + col] = n;
          total += n;
        }
      }
    }
    const std::string path = absl::StrFormat("%s/pop-%s-%g.tif", dir, pc.srs + 5, pc.pixel);
    ASSERT_TRUE(WriteRaster(path, s).ok());
    ImportOptions o = MapOptions(dem, pc.res_m);
    o.population = path;
    o.population_unit = PopulationUnit::kPerCell;
    auto map = ImportMap(o);
    ASSERT_TRUE(map.ok()) << map.status();
    EXPECT_NEAR(map->stats.people_total / total, 1.0, 1e-6)
        << pc.srs << " pixel " << pc.pixel << " cells " << pc.res_m << ": " << total
        << " people in, " << map->stats.people_total << " in the map";
    EXPECT_THAT(map->inputs[1].detail, HasSubstr("resampling sum"));
    if (pc.pixel == 100.0) {
      // 100 m pixels (99.98 m on the ground here) over 5 m cells: warped on
      // blocks of 4 x 4 cells.
      EXPECT_THAT(map->inputs[1].detail, HasSubstr("onto blocks of 4 x 4 cells"));
    }
  }
}

// People per km^2 are a density: averaged, then per m^2.
TEST(ImportResamplingTest, PopulationPerKm2IsADensity) {
  const std::string dir = FreshDir("population-density");
  RasterSpec s;
  s.srs = "EPSG:4326";
  s.width = s.height = 60;
  s.geotransform[0] = kLon - 0.03;
  s.geotransform[1] = 0.001;
  s.geotransform[3] = kLat + 0.03;
  s.geotransform[5] = -0.001;
  s.values.assign(60 * 60, 2500.0);  // people per km^2
  ASSERT_TRUE(WriteRaster(dir + "/density.tif", s).ok());
  ImportOptions o = MapOptions(FlatDem(dir), 10.0);
  o.population = dir + "/density.tif";
  o.population_unit = PopulationUnit::kPerKm2;
  auto map = ImportMap(o);
  ASSERT_TRUE(map.ok()) << map.status();
  for (float d : map->layers.density) ASSERT_NEAR(d, 2.5e-3, 1e-9);
  EXPECT_NEAR(map->stats.people_total, 2500.0 * 4.0, 0.1);
  EXPECT_THAT(map->inputs[1].detail, HasSubstr("resampling average"));
}

// Land-cover classes are never averaged: nearest when the cells are finer
// than the pixels, the most frequent class when they are coarser. Every
// shelter is one of the table's.
TEST(ImportResamplingTest, ClassesAreNeverAveraged) {
  const std::string dir = FreshDir("classes");
  auto c = testing::Carry("EPSG:4326", "EPSG:32632", kLon, kLat);
  RasterSpec s;
  s.srs = "EPSG:32632";
  s.type = GDT_Byte;
  s.width = s.height = 500;  // 10 m pixels, 5 km
  s.geotransform[0] = std::floor(c->first) - 2500;
  s.geotransform[1] = 10;
  s.geotransform[3] = std::floor(c->second) + 2500;
  s.geotransform[5] = -10;
  s.values.resize(500 * 500);
  const int classes[] = {10, 30, 50};  // tree cover 5, grassland 0, built-up 5
  for (int r = 0; r < 500; ++r) {
    for (int col = 0; col < 500; ++col) {
      s.values[static_cast<size_t>(r) * 500 + col] = classes[(r / 3 + col / 2) % 3];
    }
  }
  ASSERT_TRUE(WriteRaster(dir + "/worldcover.tif", s).ok());
  const std::string dem = FlatDem(dir);
  for (double res : {5.0, 25.0}) {
    ImportOptions o = MapOptions(dem, res);
    o.landcover = dir + "/worldcover.tif";
    auto map = ImportMap(o);
    ASSERT_TRUE(map.ok()) << map.status();
    std::set<float> values(map->layers.shelter.begin(), map->layers.shelter.end());
    EXPECT_EQ(values, (std::set<float>{0.0f, 5.0f})) << res;
    EXPECT_THAT(map->inputs[1].detail, HasSubstr(res < 10 ? "resampling near" : "resampling mode"));
  }
}

}  // namespace
}  // namespace riskplan::geo
