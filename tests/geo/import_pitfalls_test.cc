// The GIS pitfalls of an import, each pinned by inputs that GDAL itself
// writes: a known feature at a known latitude and longitude must land in the
// right cell, whatever the input's CRS, axis order, row order, rotation,
// pixel convention or mask.
#include <cmath>
#include <regex>
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
using testing::CellOfLatLon;
using testing::FreshDir;
using ::testing::HasSubstr;
using testing::RasterSpec;
using testing::WriteRaster;

constexpr double kLat = 49.6;  // the map's centre
constexpr double kLon = 6.1;

// A 2 km x 2 km map of 10 m cells around (kLat, kLon).
ImportOptions MapOptions(const std::string& terrain) {
  ImportOptions o;
  o.name = "pitfalls";
  o.area.center = LatLon{kLat, kLon};
  o.area.width_m = o.area.height_m = 2000.0;
  o.area.res_m = 10.0;
  o.terrain = terrain;
  return o;
}

std::pair<int, int> ArgMax(const std::vector<float>& layer, const MapHeader& h) {
  size_t best = 0;
  for (size_t c = 1; c < layer.size(); ++c) {
    if (layer[c] > layer[best]) best = c;
  }
  return {static_cast<int>(best % h.nx), static_cast<int>(best / h.nx)};
}

// A raster in EPSG:4326 of `pixel_deg` pixels over `half_deg` around the map
// centre, `base` everywhere but `peak` in the pixel whose centre is
// (peak_lat, peak_lon) (which must be a pixel centre).
RasterSpec Wgs84Dem(double pixel_deg, double half_deg, double base, double peak, double peak_lat,
                    double peak_lon) {
  RasterSpec s;
  s.srs = "EPSG:4326";
  const double west = kLon - half_deg, north = kLat + half_deg;
  s.width = s.height = static_cast<int>(std::lround(2 * half_deg / pixel_deg));
  s.geotransform[0] = west;
  s.geotransform[1] = pixel_deg;
  s.geotransform[2] = 0.0;
  s.geotransform[3] = north;
  s.geotransform[4] = 0.0;
  s.geotransform[5] = -pixel_deg;
  s.values.assign(static_cast<size_t>(s.width) * s.height, base);
  const int col = static_cast<int>(std::floor((peak_lon - west) / pixel_deg));
  const int row = static_cast<int>(std::floor((north - peak_lat) / pixel_deg));
  s.values[static_cast<size_t>(row) * s.width + col] = peak;
  return s;
}

// EPSG:4326 is officially latitude first; GDAL's rasters and OGR's
// geometries are longitude first. The peak lands where it is only if every
// spatial reference is read in GIS order.
TEST(ImportPitfallsTest, Epsg4326AxisOrder) {
  const std::string dir = FreshDir("axis-order");
  // A pixel centre (the raster's corner is at whole thousandths).
  const double peak_lat = kLat + 0.0035, peak_lon = kLon - 0.0045;
  ASSERT_TRUE(
      WriteRaster(dir + "/dem.tif", Wgs84Dem(0.001, 0.05, 200, 600, peak_lat, peak_lon)).ok());
  ImportOptions o = MapOptions(dir + "/dem.tif");
  // A landing site given as a point in EPSG:4326 (GeoJSON and GeoPackage),
  // and one in EPSG:3035, whose official order is northing first too.
  const double site_lat = kLat - 0.004, site_lon = kLon + 0.006;
  ASSERT_TRUE(
      testing::WriteVector(
          dir + "/sites.geojson", "GeoJSON", "EPSG:4326", "sites",
          {{absl::StrFormat("POINT (%.9f %.9f)", site_lon, site_lat), {}, {{"name", "json"}}}})
          .ok());
  ASSERT_TRUE(
      testing::WriteVector(dir + "/sites.gpkg", "GPKG", "EPSG:4326", "sites",
                           {{absl::StrFormat("POINT (%.9f %.9f)", site_lon, site_lat - 0.002),
                             {},
                             {{"name", "gpkg"}}}})
          .ok());
  auto laea = testing::Carry("EPSG:4326", "EPSG:3035", site_lon - 0.003, site_lat);
  ASSERT_TRUE(laea.ok());
  ASSERT_TRUE(
      testing::WriteVector(dir + "/sites-3035.gpkg", "GPKG", "EPSG:3035", "sites",
                           {{absl::StrFormat("POINT (%.6f %.6f)", laea->first, laea->second),
                             {},
                             {{"name", "laea"}}}})
          .ok());
  o.landing = {dir + "/sites.geojson", dir + "/sites.gpkg", dir + "/sites-3035.gpkg"};
  o.landing_name_field = "name";
  auto map = ImportMap(o);
  ASSERT_TRUE(map.ok()) << map.status();
  EXPECT_EQ(ArgMax(map->layers.terrain, map->header), CellOfLatLon(*map, peak_lat, peak_lon));
  ASSERT_EQ(map->layers.landing_sites.size(), 3u);
  const std::pair<double, double> expected[] = {
      {site_lat, site_lon}, {site_lat - 0.002, site_lon}, {site_lat, site_lon - 0.003}};
  for (int k = 0; k < 3; ++k) {
    const LandingSite& s = map->layers.landing_sites[k];
    EXPECT_EQ(std::pair(s.i, s.j), CellOfLatLon(*map, expected[k].first, expected[k].second))
        << s.name;
  }
  EXPECT_EQ(map->inputs[0].crs, "EPSG:4326");
}

// GDAL's rasters store the northernmost row first; the map's first row is the
// southernmost.
TEST(ImportPitfallsTest, NorthUpRowsBecomeSouthToNorth) {
  const std::string dir = FreshDir("north-up");
  RasterSpec s = Wgs84Dem(0.001, 0.05, 0, 0, kLat, kLon);
  // Height rises by 1 m per row going north (row 0, the first stored, highest).
  for (int r = 0; r < s.height; ++r) {
    for (int c = 0; c < s.width; ++c) s.values[static_cast<size_t>(r) * s.width + c] = 1000 - r;
  }
  ASSERT_TRUE(WriteRaster(dir + "/dem.tif", s).ok());
  auto map = ImportMap(MapOptions(dir + "/dem.tif"));
  ASSERT_TRUE(map.ok()) << map.status();
  const MapHeader& h = map->header;
  EXPECT_LT(At(map->layers.terrain, h, 100, 0), At(map->layers.terrain, h, 100, h.ny - 1));
  for (int j = 1; j < h.ny; ++j) {
    ASSERT_GE(At(map->layers.terrain, h, 100, j), At(map->layers.terrain, h, 100, j - 1)) << j;
  }
  // 2 km north is 18 rows of 0.001 deg (111 m): about 18 m higher.
  EXPECT_NEAR(At(map->layers.terrain, h, 100, h.ny - 1) - At(map->layers.terrain, h, 100, 0),
              1990.0 / 111'200.0 / 0.001, 0.3);
}

// A rotated geotransform (30 degrees, UTM zone 32N): GDAL's warper follows
// the whole affine transform.
TEST(ImportPitfallsTest, RotatedGeotransformIsWarped) {
  const std::string dir = FreshDir("rotated");
  auto centre = testing::Carry("EPSG:4326", "EPSG:32632", kLon, kLat);
  ASSERT_TRUE(centre.ok());
  RasterSpec s;
  s.srs = "EPSG:32632";
  s.width = s.height = 200;
  const double pixel = 25.0, theta = 30.0 * M_PI / 180.0;
  // Pixel (p, l) is at corner + p * (cos, sin) * pixel + l * (sin, -cos) * pixel.
  s.geotransform[1] = pixel * std::cos(theta);
  s.geotransform[2] = pixel * std::sin(theta);
  s.geotransform[4] = pixel * std::sin(theta);
  s.geotransform[5] = -pixel * std::cos(theta);
  // The raster's centre on the map's centre.
  s.geotransform[0] = centre->first - 100 * (s.geotransform[1] + s.geotransform[2]);
  s.geotransform[3] = centre->second - 100 * (s.geotransform[4] + s.geotransform[5]);
  s.values.assign(200 * 200, 300.0);
  const int peak_p = 117, peak_l = 74;
  s.values[static_cast<size_t>(peak_l) * 200 + peak_p] = 700.0;
  ASSERT_TRUE(WriteRaster(dir + "/dem.tif", s).ok());
  const double pc = peak_p + 0.5, lc = peak_l + 0.5;
  const double e = s.geotransform[0] + pc * s.geotransform[1] + lc * s.geotransform[2];
  const double n = s.geotransform[3] + pc * s.geotransform[4] + lc * s.geotransform[5];
  auto peak = testing::Carry("EPSG:32632", "EPSG:4326", e, n);
  ASSERT_TRUE(peak.ok());
  auto map = ImportMap(MapOptions(dir + "/dem.tif"));
  ASSERT_TRUE(map.ok()) << map.status();
  EXPECT_EQ(ArgMax(map->layers.terrain, map->header),
            CellOfLatLon(*map, peak->second, peak->first));
  EXPECT_THAT(map->inputs[0].detail, HasSubstr("rotated"));
}

// SRTM .hgt samples are points: sample (r, c) of tile N49E006 lies exactly at
// (50 - r/1200, 6 + c/1200), and GDAL's geotransform starts half a sample
// north-west of it. A GeoTIFF whose tie point is its first pixel's centre
// (AREA_OR_POINT=Point) is read the same way.
TEST(ImportPitfallsTest, PixelIsPointRastersAreShiftedHalfAPixel) {
  const std::string dir = FreshDir("pixel-is-point");
  RasterSpec hgt;
  hgt.driver = "SRTMHGT";
  hgt.type = GDT_Int16;
  hgt.width = hgt.height = 1201;
  const double step = 1.0 / 1200;
  hgt.geotransform[0] = 6.0 - step / 2;
  hgt.geotransform[1] = step;
  hgt.geotransform[3] = 50.0 + step / 2;
  hgt.geotransform[5] = -step;
  hgt.area_or_point = "Point";
  hgt.values.assign(1201 * 1201, 300.0);
  const int r = 478, c = 121;
  hgt.values[static_cast<size_t>(r) * 1201 + c] = 800.0;
  ASSERT_TRUE(WriteRaster(dir + "/N49E006.hgt", hgt).ok());
  auto map = ImportMap(MapOptions(dir + "/N49E006.hgt"));
  ASSERT_TRUE(map.ok()) << map.status();
  const double lat = 50.0 - r * step, lon = 6.0 + c * step;
  EXPECT_EQ(ArgMax(map->layers.terrain, map->header), CellOfLatLon(*map, lat, lon));
  EXPECT_THAT(map->inputs[0].detail, HasSubstr("pixel is Point"));
  // Half a sample is 46 m north-south and 30 m east-west: a reader taking
  // the sample for a pixel corner would miss by 3 to 5 cells.
  EXPECT_NE(ArgMax(map->layers.terrain, map->header),
            CellOfLatLon(*map, lat - step / 2, lon + step / 2));

  RasterSpec tif;
  tif.srs = "EPSG:4326";
  tif.width = tif.height = 121;
  tif.geotransform[0] = 6.05;  // the first pixel's centre, not its corner
  tif.geotransform[1] = step;
  tif.geotransform[3] = 49.65;
  tif.geotransform[5] = -step;
  tif.area_or_point = "Point";
  tif.raw_point_tiepoint = true;
  tif.values.assign(121 * 121, 300.0);
  tif.values[static_cast<size_t>(50) * 121 + 70] = 800.0;  // at (49.65 - 50 s, 6.05 + 70 s)
  ASSERT_TRUE(WriteRaster(dir + "/point.tif", tif).ok());
  map = ImportMap(MapOptions(dir + "/point.tif"));
  ASSERT_TRUE(map.ok()) << map.status();
  EXPECT_EQ(ArgMax(map->layers.terrain, map->header),
            CellOfLatLon(*map, 49.65 - 50 * step, 6.05 + 70 * step));
}

// A UTM DEM whose south-west quarter is masked by a mask band (no nodata
// value; the masked pixels hold 9999): the mask, not a sentinel, says what
// has no data.
TEST(ImportPitfallsTest, NodataComesFromTheMaskBand) {
  const std::string dir = FreshDir("mask");
  auto centre = testing::Carry("EPSG:4326", "EPSG:32632", kLon, kLat);
  ASSERT_TRUE(centre.ok());
  RasterSpec s;
  s.srs = "EPSG:32632";
  s.width = s.height = 160;  // 4 km of 25 m pixels
  s.geotransform[0] = std::floor(centre->first) - 2000;
  s.geotransform[1] = 25;
  s.geotransform[3] = std::floor(centre->second) + 2000;
  s.geotransform[5] = -25;
  s.values.assign(160 * 160, 250.0);
  s.mask.assign(160 * 160, 1);
  for (int r = 80; r < 160; ++r) {
    for (int c = 0; c < 80; ++c) {
      s.values[static_cast<size_t>(r) * 160 + c] = 9999.0;
      s.mask[static_cast<size_t>(r) * 160 + c] = 0;
    }
  }
  ASSERT_TRUE(WriteRaster(dir + "/dem.tif", s).ok());
  ImportOptions o = MapOptions(dir + "/dem.tif");
  auto refused = ImportMap(o);
  ASSERT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument);
  const std::string m(refused.status().message());
  EXPECT_THAT(m, HasSubstr("layer 'terrain', input '" + dir + "/dem.tif'"));
  EXPECT_THAT(m, HasSubstr("(0 outside the input's extent"));
  EXPECT_THAT(m, HasSubstr("masked inside it"));
  EXPECT_THAT(m, HasSubstr("--fill_terrain"));
  EXPECT_THAT(m, HasSubstr("cells (0 .. "));  // the south-west quarter
  o.terrain_fill.kind = FillRule::Kind::kNearest;
  auto map = ImportMap(o);
  ASSERT_TRUE(map.ok()) << map.status();
  for (float t : map->layers.terrain) ASSERT_EQ(t, 250.0f);
  EXPECT_GT(map->stats.filled_terrain_cells, 9000);
  EXPECT_LT(map->stats.filled_terrain_cells, 11000);
  EXPECT_THAT(map->inputs[0].detail, HasSubstr("mask band"));

  // The same pixels with 9999 declared as the nodata value: the same cells.
  s.mask.clear();
  s.has_nodata = true;
  s.nodata = 9999.0;
  ASSERT_TRUE(WriteRaster(dir + "/dem-nodata.tif", s).ok());
  o.terrain = dir + "/dem-nodata.tif";
  auto with_nodata = ImportMap(o);
  ASSERT_TRUE(with_nodata.ok()) << with_nodata.status();
  EXPECT_EQ(with_nodata->stats.filled_terrain_cells, map->stats.filled_terrain_cells);
  // And undeclared: -32768 read as a height is refused, not flown over.
  s.has_nodata = false;
  for (double& v : s.values) v = v == 9999.0 ? -32768.0 : v;
  ASSERT_TRUE(WriteRaster(dir + "/dem-undeclared.tif", s).ok());
  o.terrain = dir + "/dem-undeclared.tif";
  EXPECT_THAT(ImportMap(o).status().message(),
              HasSubstr("a nodata value the file does not declare"));
}

// An input that does not cover the map is refused, naming the uncovered
// extent in the local frame, WGS84 and the input's CRS; a fill flag says
// what to put there instead.
TEST(ImportPitfallsTest, InputsNotCoveringTheMapAreRefusedWithTheExtent) {
  const std::string dir = FreshDir("coverage");
  auto centre = testing::Carry("EPSG:4326", "EPSG:32632", kLon, kLat);
  ASSERT_TRUE(centre.ok());
  RasterSpec s;
  s.srs = "EPSG:32632";
  s.width = 80;  // 2 km of 25 m pixels, from 1.5 km west of the centre to 0.5 km east
  s.height = 160;
  const double east_edge = std::floor(centre->first) + 500;
  s.geotransform[0] = east_edge - 2000;
  s.geotransform[1] = 25;
  s.geotransform[3] = std::floor(centre->second) + 2000;
  s.geotransform[5] = -25;
  s.values.assign(80 * 160, 280.0);
  ASSERT_TRUE(WriteRaster(dir + "/west.tif", s).ok());
  ImportOptions o = MapOptions(dir + "/west.tif");
  auto refused = ImportMap(o);
  ASSERT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument);
  const std::string m(refused.status().message());
  EXPECT_THAT(m, HasSubstr("layer 'terrain', input '" + dir + "/west.tif'"));
  // About the east quarter of the map (the UTM grid is turned 2 degrees
  // from the map's): all outside the extent, none masked.
  std::smatch g;
  ASSERT_TRUE(std::regex_search(
      m, g,
      std::regex(
          R"((\d+) of 40000 cells have no data \((\d+) outside the input's extent, 0 masked)")))
      << m;
  EXPECT_EQ(g[1], g[2]);
  EXPECT_NEAR(std::stod(g[1]), 10000, 1000);
  ASSERT_TRUE(std::regex_search(m, g, std::regex(R"(local x ([0-9.]+) \.\. ([0-9.]+) m)"))) << m;
  EXPECT_NEAR(std::stod(g[1]), 1500, 50);
  EXPECT_EQ(std::stod(g[2]), 2000);
  ASSERT_TRUE(std::regex_search(
      m, g, std::regex(R"(WGS84 lat ([0-9.]+) \.\. ([0-9.]+), lon ([0-9.]+) \.\. ([0-9.]+) deg)")))
      << m;
  auto east = testing::Carry("EPSG:32632", "EPSG:4326", east_edge, centre->second);
  EXPECT_NEAR(std::stod(g[3]), east->first, 0.001);              // the DEM's east edge
  EXPECT_NEAR(std::stod(g[4]), kLon + 1000 / 72'200.0, 0.0005);  // the map's east edge
  ASSERT_TRUE(
      std::regex_search(m, g, std::regex(R"(input CRS EPSG:32632 x ([0-9.]+) \.\. ([0-9.]+), y)")))
      << m;
  // The extent's box, carried into UTM (turned 2.2 degrees), reaches
  // 2000 m * tan(2.2 deg) = 77 m further west than the DEM's edge.
  EXPECT_NEAR(std::stod(g[1]), east_edge - 77, 30);
  EXPECT_THAT(m, HasSubstr("--fill_terrain=METRES|nearest"));

  o.terrain_fill = {FillRule::Kind::kValue, 123.0};
  auto map = ImportMap(o);
  ASSERT_TRUE(map.ok()) << map.status();
  EXPECT_EQ(At(map->layers.terrain, map->header, map->header.nx - 1, 100), 123.0f);
  EXPECT_EQ(At(map->layers.terrain, map->header, 0, 100), 280.0f);
}

// Web Mercator (EPSG:3857): its metres are 1/cos(lat) = 1.54 ground metres
// here; the warp, not a scale factor, puts the peak in place.
TEST(ImportPitfallsTest, WebMercatorRaster) {
  const std::string dir = FreshDir("mercator");
  auto centre = testing::Carry("EPSG:4326", "EPSG:3857", kLon, kLat);
  ASSERT_TRUE(centre.ok());
  RasterSpec s;
  s.srs = "EPSG:3857";
  s.width = s.height = 300;
  s.geotransform[0] = centre->first - 3000;
  s.geotransform[1] = 20;
  s.geotransform[3] = centre->second + 3000;
  s.geotransform[5] = -20;
  s.values.assign(300 * 300, 150.0);
  s.values[static_cast<size_t>(120) * 300 + 201] = 450.0;
  ASSERT_TRUE(WriteRaster(dir + "/dem.tif", s).ok());
  auto peak = testing::Carry("EPSG:3857", "EPSG:4326", s.geotransform[0] + 201.5 * 20,
                             s.geotransform[3] - 120.5 * 20);
  ASSERT_TRUE(peak.ok());
  auto map = ImportMap(MapOptions(dir + "/dem.tif"));
  ASSERT_TRUE(map.ok()) << map.status();
  EXPECT_EQ(ArgMax(map->layers.terrain, map->header),
            CellOfLatLon(*map, peak->second, peak->first));
}

}  // namespace
}  // namespace riskplan::geo
