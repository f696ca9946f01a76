// Real data from Debian packages (scripts/fetch-geodata.sh: r-cran-terra's
// Luxembourg DEM and cantons, its Meuse raster in the Dutch RD projection,
// r-cran-satellite's UTM DEM): a map of the whole country whose people are
// the cantons', DEMs in other CRSs sampled where they should be, and a map of
// Luxembourg city imported, served and planned on end to end.
#include <gdal_priv.h>
#include <ogrsf_frmts.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_format.h"
#include "core/map/map_bundle.h"
#include "geo/gdal_util.h"
#include "geo/map_importer.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/geo/geodata_fixtures.h"
#include "tests/integration/server_process.h"

namespace riskplan::geo {
namespace {

using ::riskplan::testing::RunCommand;
using ::riskplan::testing::ServerProcess;
using testing::At;
using testing::CellOfLatLon;
using testing::FreshDir;
using ::testing::HasSubstr;
using testing::RealGeodataDir;

// The data, or a failed test: these tests never skip.
std::string Data(const std::string& file) {
  auto dir = RealGeodataDir();
  EXPECT_TRUE(dir.ok()) << dir.status();
  return dir.ok() ? *dir + "/" + file : "/nonexistent/" + file;
}

// Band 1 of a raster, north row first, and its geotransform.
struct Raster {
  int width = 0, height = 0;
  double gt[6] = {};
  std::vector<double> values;
  double At(int p, int l) const { return values[static_cast<size_t>(l) * width + p]; }
  // Bilinear between pixel centres at georeferenced (x, y) (north-up only).
  double Bilinear(double x, double y) const {
    const double p = (x - gt[0]) / gt[1] - 0.5, l = (y - gt[3]) / gt[5] - 0.5;
    const int p0 = static_cast<int>(std::floor(p)), l0 = static_cast<int>(std::floor(l));
    const double fp = p - p0, fl = l - l0;
    return (1 - fp) * (1 - fl) * At(p0, l0) + fp * (1 - fl) * At(p0 + 1, l0) +
           (1 - fp) * fl * At(p0, l0 + 1) + fp * fl * At(p0 + 1, l0 + 1);
  }
};

Raster Read(const std::string& path) {
  EnsureGdalRegistered();
  Raster r;
  GDALDatasetUniquePtr ds(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER));
  EXPECT_NE(ds, nullptr) << path;
  if (ds == nullptr) return r;
  r.width = ds->GetRasterXSize();
  r.height = ds->GetRasterYSize();
  ds->GetGeoTransform(r.gt);
  r.values.resize(static_cast<size_t>(r.width) * r.height);
  EXPECT_EQ(ds->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, r.width, r.height, r.values.data(),
                                           r.width, r.height, GDT_Float64, 0, 0, nullptr),
            CE_None);
  return r;
}

double CantonsPopulation(const std::string& shp) {
  EnsureGdalRegistered();
  GDALDatasetUniquePtr ds(GDALDataset::Open(shp.c_str(), GDAL_OF_VECTOR));
  EXPECT_NE(ds, nullptr);
  double total = 0.0;
  if (ds == nullptr) return total;
  for (auto& f : *ds->GetLayer(0)) total += f->GetFieldAsDouble("POP");
  return total;
}

TEST(LuxembourgTest, CountryMapHoldsTheCantonsPeople) {
  const std::string elev = Data("terra/ex/elev.tif");
  const std::string lux = Data("terra/ex/lux.shp");
  const double cantons = CantonsPopulation(lux);
  EXPECT_EQ(cantons, 602005.0);  // the 12 cantons' POP
  ImportOptions o;
  o.name = "luxembourg";
  o.area.bbox = LonLatBox{5.73, 49.44, 6.54, 50.19};
  o.area.res_m = 100.0;
  o.terrain = elev;
  o.population = lux;
  o.population_field = "POP";
  // The DEM and the cantons end at the border: beyond it, the nearest
  // height and nobody.
  o.terrain_fill.kind = FillRule::Kind::kNearest;
  o.density_fill = {FillRule::Kind::kValue, 0.0};
  auto map = ImportMap(o);
  ASSERT_TRUE(map.ok()) << map.status();
  EXPECT_EQ(map->header.nx, 588);
  EXPECT_EQ(map->header.ny, 838);
  EXPECT_NEAR(map->stats.people_total, cantons, 1e-4 * cantons);
  EXPECT_THAT(map->inputs[1].detail, HasSubstr("12 polygons meet the map"));
  // elev.tif holds 141 .. 547 m.
  EXPECT_GE(map->stats.terrain_min_m, 141.0);
  EXPECT_LE(map->stats.terrain_max_m, 547.0);
  EXPECT_GT(map->stats.terrain_max_m, 500.0);
  // Luxembourg canton: 182607 people on about 237 km^2.
  auto [i, j] = CellOfLatLon(*map, 49.6116, 6.1319);
  EXPECT_NEAR(At(map->layers.density, map->header, i, j), 182607.0 / 237e6, 0.03 * 182607 / 237e6);
  // Luxembourg's own DEM pixel under Luxembourg city, read back.
  const Raster dem = Read(elev);
  auto [ci, cj] = CellOfLatLon(*map, 49.6116, 6.1319);
  EXPECT_NEAR(At(map->layers.terrain, map->header, ci, cj), dem.Bilinear(6.1319, 49.6116), 3.0);
}

// r-cran-satellite's DEM: 41 x 41 pixels of 30 m in UTM zone 32N near
// Marburg. A 1 km map inside it holds, at each cell, the DEM's bilinear
// height there; a 2 km map is refused with the uncovered extent in UTM.
TEST(LuxembourgTest, SatelliteUtmDem) {
  const std::string path = Data("satellite/extdata/DEM.TIF");
  const Raster dem = Read(path);
  auto centre = testing::Carry("EPSG:32632", "EPSG:4326", 483900.0, 5627910.0);
  ASSERT_TRUE(centre.ok());
  ImportOptions o;
  o.name = "marburg";
  o.area.center = LatLon{centre->second, centre->first};
  o.area.width_m = o.area.height_m = 1000.0;
  o.area.res_m = 5.0;
  o.terrain = path;
  auto map = ImportMap(o);
  ASSERT_TRUE(map.ok()) << map.status();
  EXPECT_EQ(map->inputs[0].crs, "EPSG:32632");
  auto frame = FrameOfMap(map->header);
  ASSERT_TRUE(frame.ok());
  for (int j = 3; j < map->header.ny; j += 37) {
    for (int i = 5; i < map->header.nx; i += 41) {
      auto ll = frame->ToWgs84(LocalXY{(i + 0.5) * 5.0, (j + 0.5) * 5.0});
      auto en = testing::Carry("EPSG:4326", "EPSG:32632", ll->lon_deg, ll->lat_deg);
      EXPECT_NEAR(At(map->layers.terrain, map->header, i, j), dem.Bilinear(en->first, en->second),
                  0.05)
          << i << ", " << j;
    }
  }
  o.area.width_m = o.area.height_m = 2000.0;
  auto refused = ImportMap(o);
  ASSERT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(refused.status().message(), HasSubstr("layer 'terrain', input '" + path + "'"));
  EXPECT_THAT(refused.status().message(), HasSubstr("input CRS EPSG:32632 x 48"));
  EXPECT_THAT(refused.status().message(), HasSubstr("outside the input's extent, 0 masked"));
}

// r-cran-terra's meuse.tif is in the Dutch RD projection, written without an
// EPSG code: GDAL's warp needs none.
TEST(LuxembourgTest, MeuseRasterInRdWithoutAnEpsgCode) {
  const std::string path = Data("terra/ex/meuse.tif");
  const Raster r = Read(path);
  // Its centre, (180000, 331700) in RD.
  ImportOptions o;
  o.name = "meuse";
  o.area.center = LatLon{50.975419, 5.743583};
  o.area.width_m = o.area.height_m = 1200.0;
  o.area.res_m = 10.0;
  o.terrain = path;
  o.terrain_fill.kind = FillRule::Kind::kNearest;  // the raster has nodata around the river
  auto map = ImportMap(o);
  ASSERT_TRUE(map.ok()) << map.status();
  EXPECT_THAT(map->inputs[0].crs, HasSubstr("Oblique_Stereographic"));
  EXPECT_THAT(map->inputs[0].crs_wkt, HasSubstr("Oblique Stereographic"));
  EXPECT_GE(map->stats.terrain_min_m, 138.0);
  EXPECT_LE(map->stats.terrain_max_m, 1736.0);
}

std::string ToolCommand(const std::string& args) {
  return std::string(RISKPLAN_BIN_DIR) + "/riskplan-tool " + args + " 2>&1";
}

// Luxembourg city, 8 km x 8 km at 10 m: terrain from the DEM, people from
// the cantons, no-fly zones around Findel airport's runway and a hospital
// (buffered by 300 m), 25 landing sites (tests/data/geo/). Imported with
// riskplan-tool, served by riskplan-server, planned on with `riskplan plan`,
// and the plan checked again offline with `riskplan-tool evaluate`.
TEST(LuxembourgTest, CityMapPlannedEndToEnd) {
  const std::string ex = Data("terra/ex");
  const std::string data = std::string(RISKPLAN_SOURCE_DIR) + "/tests/data/geo";
  const std::string maps = FreshDir("luxembourg-city");
  const std::string bundle = maps + "/luxembourg-city";
  auto r = RunCommand(ToolCommand(absl::StrFormat(
      "import --out=%s --center=49.6116,6.1319 --size_m=8000 --res_m=10 --terrain=%s/elev.tif "
      "--population=%s/lux.shp --population_field=POP --base_shelter=5 "
      "--nofly=%s/luxembourg-nofly.geojson --nofly_buffer_m=300 "
      "--landing=%s/luxembourg-landing.geojson --landing_name_field=name",
      bundle, ex, ex, data, data)));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("map           luxembourg-city: 800 x 800 cells of 10 m"));
  EXPECT_THAT(r.output, HasSubstr("landing sites 25"));
  auto map = LoadMapBundle(bundle);
  ASSERT_TRUE(map.ok()) << map.status();
  const RiskMap& m = **map;
  int64_t nofly = 0;
  for (uint8_t z : m.layers().nofly) nofly += z;
  EXPECT_GT(nofly, 5000);  // the hospital's disc and the runway's west end

  // A start in the south-west and a goal in the north-east, 1.5 km from the
  // edges (the impact windows stay inside the map), midway up the band
  // between the safe altitude and max_agl.
  auto pose = [&](double x, double y) {
    const int i = static_cast<int>(x / 10), j = static_cast<int>(y / 10);
    const double lo = m.SafeAltitude(i, j, 30.0), hi = m.terrain(i, j) + 150.0;
    EXPECT_LT(lo + 10.0, hi) << x << ", " << y;
    return absl::StrFormat("%.0f,%.0f,%.1f,0.785", x, y, 0.5 * (lo + hi));
  };
  const std::string start = pose(1500, 1500), goal = pose(6500, 6500);

  auto server = ServerProcess::Start({"--maps=" + maps});
  ASSERT_TRUE(server.ok()) << server.status();
  const std::string trajectory = maps + "/plan.json";
  r = RunCommand(absl::StrFormat(
      "%s/riskplan %s plan --map=luxembourg-city --start=%s --goal=%s --budget_ms=4000 "
      "--seed=7 --trajectory_out=%s 2>&1",
      RISKPLAN_BIN_DIR, (*server)->CliServerFlags(), start, goal, trajectory));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const size_t at = r.output.find("best: risk ");
  ASSERT_NE(at, std::string::npos) << r.output;
  double risk = 0.0;
  ASSERT_TRUE(
      absl::SimpleAtod(r.output.substr(at + 11, r.output.find(' ', at + 11) - at - 11), &risk))
      << r.output;
  EXPECT_GT(risk, 0.0);
  EXPECT_LT(risk, 1e-5);
  std::printf("luxembourg-city plan %s -> %s: %s\n", start.c_str(), goal.c_str(),
              r.output.substr(at, r.output.find('\n', at) - at).c_str());

  // The same trajectory evaluated offline: admissible, the same risk.
  r = RunCommand(ToolCommand(
      absl::StrFormat("evaluate --map=%s --trajectory_file=%s --json", bundle, trajectory)));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json eval = nlohmann::json::parse(r.output);
  EXPECT_TRUE(eval["admissible"].get<bool>());
  EXPECT_NEAR(eval["risk"].get<double>(), risk, 1e-6 * risk);
}

}  // namespace
}  // namespace riskplan::geo
