// Every kind of input an import reads, and its refusals: census polygons,
// buildings (vector and OpenStreetMap), land cover, no-fly zones, landing
// sites.
#include <cpl_error.h>
#include <ogr_api.h>
#include <ogr_geometry.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "geo/gdal_util.h"
#include "geo/map_importer.h"
#include "geo/target_grid.h"
#include "geo/vector_input.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/geo/geodata_fixtures.h"

namespace riskplan::geo {
namespace {

using testing::At;
using testing::CellOfLatLon;
using testing::FeatureSpec;
using testing::FreshDir;
using ::testing::HasSubstr;
using testing::RasterSpec;
using testing::WriteRaster;
using testing::WriteVector;

constexpr double kLat = 49.6;
constexpr double kLon = 6.1;

ImportOptions MapOptions(const std::string& dir) {
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
  ImportOptions o;
  o.name = "inputs";
  o.area.center = LatLon{kLat, kLon};
  o.area.width_m = o.area.height_m = 2000.0;
  o.area.res_m = 10.0;
  o.terrain = dir + "/flat.tif";
  return o;
}

// The map's own frame as a CRS, so that a test can draw features on its
// cells exactly.
std::string FrameCrs(const ImportOptions& o) {
  auto grid = MakeTargetGrid(o.area);
  EXPECT_TRUE(grid.ok());
  return grid->frame.proj_definition();
}

std::string Rect(double x0, double y0, double x1, double y1) {
  return absl::StrFormat("POLYGON ((%f %f, %f %f, %f %f, %f %f, %f %f))", x0, y0, x1, y0, x1, y1,
                         x0, y1, x0, y0);
}

// Two census districts in UTM, each a 6 km x 3 km rectangle (18 km^2),
// reaching far beyond the map: each cell gets its district's people per
// area.
TEST(ImportInputsTest, CensusPolygonsSpreadOverTheirArea) {
  const std::string dir = FreshDir("census");
  ImportOptions o = MapOptions(dir);
  auto c = testing::Carry("EPSG:4326", "EPSG:32632", kLon, kLat);
  const double e = std::floor(c->first), n = std::floor(c->second);
  ASSERT_TRUE(WriteVector(dir + "/census.gpkg", "GPKG", "EPSG:32632", "districts",
                          {{Rect(e - 3000, n - 3000, e + 3000, n), {{"POP", 18000}}},
                           {Rect(e - 3000, n, e + 3000, n + 3000), {{"POP", 36000}}}})
                  .ok());
  o.population = dir + "/census.gpkg";
  o.population_field = "POP";
  auto map = ImportMap(o);
  ASSERT_TRUE(map.ok()) << map.status();
  const MapHeader& h = map->header;
  // UTM's scale near 6.1 E is 1.00028 (area 1.00056): 1000 and 2000 per km^2.
  const double scale2 = 1.00056;
  EXPECT_NEAR(At(map->layers.density, h, 100, 10), 1e-3 * scale2, 2e-6);
  EXPECT_NEAR(At(map->layers.density, h, 100, 190), 2e-3 * scale2, 4e-6);
  EXPECT_NEAR(map->stats.people_total, 1500.0 * 4.0 * scale2, 30.0);
  EXPECT_THAT(map->inputs[1].detail, HasSubstr("2 polygons meet the map"));

  // A district that does not cover the map: the cells in none are refused.
  ASSERT_TRUE(WriteVector(dir + "/south.gpkg", "GPKG", "EPSG:32632", "districts",
                          {{Rect(e - 3000, n - 3000, e + 3000, n), {{"POP", 18000}}}})
                  .ok());
  o.population = dir + "/south.gpkg";
  auto refused = ImportMap(o);
  ASSERT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(refused.status().message(),
              HasSubstr("layer 'population', input '" + dir + "/south.gpkg' (layer 'districts')"));
  EXPECT_THAT(refused.status().message(), HasSubstr("cells lie in no feature of the input"));
  EXPECT_THAT(refused.status().message(), HasSubstr("--fill_density"));
  o.density_fill = {FillRule::Kind::kValue, 0.0};
  map = ImportMap(o);
  ASSERT_TRUE(map.ok()) << map.status();
  EXPECT_EQ(At(map->layers.density, map->header, 100, 190), 0.0f);
  EXPECT_GT(map->stats.filled_density_cells, 15000);

  // Refusals: no such field, a count that is not one, a point.
  o.population_field = "PEOPLE";
  EXPECT_THAT(ImportMap(o).status().message(), HasSubstr("no field 'PEOPLE'; it has: POP"));
  ASSERT_TRUE(WriteVector(dir + "/bad.gpkg", "GPKG", "EPSG:32632", "districts",
                          {{Rect(e - 3000, n - 3000, e + 3000, n + 3000), {{"POP", -5}}}})
                  .ok());
  o.population = dir + "/bad.gpkg";
  o.population_field = "POP";
  EXPECT_THAT(ImportMap(o).status().message(),
              HasSubstr("feature 1 has -5 in 'POP'; a population count must be a number >= 0"));
}

// With buildings, a district's people in the map live under its roofs.
TEST(ImportInputsTest, CensusPolygonsSpreadOverBuiltUpArea) {
  const std::string dir = FreshDir("census-buildings");
  ImportOptions o = MapOptions(dir);
  const std::string frame = FrameCrs(o);
  // A district inside the map, 1 km x 1 km, of 1000 people, with two
  // buildings of 100 m x 100 m and 50 m x 100 m on whole cells.
  ASSERT_TRUE(WriteVector(dir + "/district.gpkg", "GPKG", frame, "district",
                          {{Rect(500, 500, 1500, 1500), {{"POP", 1000}}}})
                  .ok());
  ASSERT_TRUE(WriteVector(dir + "/buildings.gpkg", "GPKG", frame, "buildings",
                          {{Rect(600, 600, 700, 700)}, {Rect(1200, 1300, 1250, 1400)}})
                  .ok());
  o.population = dir + "/district.gpkg";
  o.population_field = "POP";
  o.buildings = dir + "/buildings.gpkg";
  o.density_fill = {FillRule::Kind::kValue, 0.0};
  auto map = ImportMap(o);
  ASSERT_TRUE(map.ok()) << map.status();
  const MapHeader& h = map->header;
  EXPECT_NEAR(map->stats.people_total, 1000.0, 1.0);
  // 15000 m^2 of roofs: 1000/15000 people per m^2 under them, none between.
  EXPECT_NEAR(At(map->layers.density, h, 65, 65), 1000.0 / 15000.0, 1e-5);
  EXPECT_NEAR(At(map->layers.density, h, 122, 135), 1000.0 / 15000.0, 1e-5);
  EXPECT_EQ(At(map->layers.density, h, 100, 100), 0.0f);
}

// Building footprints raise the shelter: a cell half under roofs counts as
// fully built up (7.5), a quarter as half way from the ground's shelter.
TEST(ImportInputsTest, BuildingsRaiseShelterByBuiltUpShare) {
  const std::string dir = FreshDir("buildings");
  ImportOptions o = MapOptions(dir);
  const std::string frame = FrameCrs(o);
  // (GeoPackage: GeoJSON is WGS84 by definition, RFC 7946.)
  ASSERT_TRUE(WriteVector(dir + "/buildings.gpkg", "GPKG", frame, "buildings",
                          {{Rect(100, 100, 200, 200)},   // cells 10..19 whole
                           {Rect(300, 300, 305, 310)},   // cell (30, 30) half
                           {Rect(500, 500, 505, 505)}})  // cell (50, 50) a quarter
                  .ok());
  o.buildings = dir + "/buildings.gpkg";
  auto map = ImportMap(o);
  ASSERT_TRUE(map.ok()) << map.status();
  const MapHeader& h = map->header;
  EXPECT_EQ(At(map->layers.shelter, h, 15, 15), 7.5f);
  EXPECT_EQ(At(map->layers.shelter, h, 30, 30), 7.5f);
  EXPECT_EQ(At(map->layers.shelter, h, 50, 50), 5.0f);  // 2.5 + (7.5 - 2.5) * 0.25 / 0.5
  EXPECT_EQ(At(map->layers.shelter, h, 80, 80), 2.5f);
  EXPECT_THAT(map->inputs[1].detail, HasSubstr("3 footprints meet the map"));
}

// An OpenStreetMap file: its buildings raise the shelter, its other areas
// do not.
TEST(ImportInputsTest, OpenStreetMapBuildings) {
  const std::string dir = FreshDir("osm");
  ImportOptions o = MapOptions(dir);
  // A 100 m square building and a park of the same size, 300 m apart.
  auto square = [](int first_id, double lat, double lon) {
    std::string nodes;
    const double dlat = 100.0 / 111'200.0, dlon = 100.0 / 72'100.0;
    const double corners[4][2] = {
        {lat, lon}, {lat, lon + dlon}, {lat + dlat, lon + dlon}, {lat + dlat, lon}};
    for (int k = 0; k < 4; ++k) {
      nodes += absl::StrFormat("  <node id=\"%d\" version=\"1\" lat=\"%.7f\" lon=\"%.7f\"/>\n",
                               first_id + k, corners[k][0], corners[k][1]);
    }
    return nodes;
  };
  auto way = [](int id, int first_node, const char* key, const char* value) {
    return absl::StrFormat(
        "  <way id=\"%d\" version=\"1\">\n    <nd ref=\"%d\"/><nd ref=\"%d\"/><nd ref=\"%d\"/>"
        "<nd ref=\"%d\"/><nd ref=\"%d\"/>\n    <tag k=\"%s\" v=\"%s\"/>\n  </way>\n",
        id, first_node, first_node + 1, first_node + 2, first_node + 3, first_node, key, value);
  };
  std::ofstream(dir + "/city.osm")
      << "<?xml version='1.0' encoding='UTF-8'?>\n"
      << "<osm version=\"0.6\" generator=\"riskplan test\">\n"
      << square(1, kLat, kLon) << square(11, kLat, kLon + 0.004) << way(100, 1, "building", "yes")
      << way(101, 11, "leisure", "park") << "</osm>\n";
  o.buildings = dir + "/city.osm";
  auto map = ImportMap(o);
  ASSERT_TRUE(map.ok()) << map.status();
  auto [bi, bj] = CellOfLatLon(*map, kLat + 0.0004, kLon + 0.0007);
  auto [pi, pj] = CellOfLatLon(*map, kLat + 0.0004, kLon + 0.0047);
  EXPECT_EQ(At(map->layers.shelter, map->header, bi, bj), 7.5f);
  EXPECT_EQ(At(map->layers.shelter, map->header, pi, pj), 2.5f);
  EXPECT_THAT(map->inputs[1].detail, HasSubstr("OSM"));
  EXPECT_THAT(map->inputs[1].detail, HasSubstr("where building IS NOT NULL"));
  EXPECT_THAT(map->inputs[1].detail, HasSubstr("1 footprints meet the map"));
}

// Land cover through the class table, a file's rules over it, and a class
// with no rule refused.
TEST(ImportInputsTest, LandCoverShelterAndItsTable) {
  const std::string dir = FreshDir("landcover");
  ImportOptions o = MapOptions(dir);
  auto c = testing::Carry("EPSG:4326", "EPSG:32632", kLon, kLat);
  RasterSpec s;
  s.srs = "EPSG:32632";
  s.type = GDT_Byte;
  s.width = s.height = 300;
  s.geotransform[0] = std::floor(c->first) - 1500;
  s.geotransform[1] = 10;
  s.geotransform[3] = std::floor(c->second) + 1500;
  s.geotransform[5] = -10;
  s.values.assign(300 * 300, 50);  // built-up
  for (int r = 0; r < 300; ++r) {
    for (int col = 150; col < 300; ++col) s.values[static_cast<size_t>(r) * 300 + col] = 30;
  }
  ASSERT_TRUE(WriteRaster(dir + "/lc.tif", s).ok());
  o.landcover = dir + "/lc.tif";
  auto map = ImportMap(o);
  ASSERT_TRUE(map.ok()) << map.status();
  EXPECT_EQ(At(map->layers.shelter, map->header, 20, 100), 5.0f);   // west: built-up
  EXPECT_EQ(At(map->layers.shelter, map->header, 180, 100), 0.0f);  // east: grassland
  std::ofstream(dir + "/table.txt") << "30 1.25 landing\n";
  o.shelter_table_file = dir + "/table.txt";
  map = ImportMap(o);
  ASSERT_TRUE(map.ok()) << map.status();
  EXPECT_EQ(At(map->layers.shelter, map->header, 180, 100), 1.25f);
  EXPECT_THAT(map->inputs[1].detail, HasSubstr("classes 'worldcover + " + dir + "/table.txt'"));

  s.values[static_cast<size_t>(150) * 300 + 150] = 37;
  ASSERT_TRUE(WriteRaster(dir + "/lc37.tif", s).ok());
  o.landcover = dir + "/lc37.tif";
  auto refused = ImportMap(o);
  EXPECT_THAT(refused.status().message(), HasSubstr("layer 'land cover', input '" + dir +
                                                    "/lc37.tif': 1 classes have no "
                                                    "rule in the 'worldcover + " +
                                                    dir + "/table.txt' table: 37 ("));
}

// No-fly zones: every cell a polygon touches; a point buffered to a disc.
TEST(ImportInputsTest, NoFlyPolygonsAndBufferedPoints) {
  const std::string dir = FreshDir("nofly");
  ImportOptions o = MapOptions(dir);
  const std::string frame = FrameCrs(o);
  ASSERT_TRUE(
      WriteVector(dir + "/zones.gpkg", "GPKG", frame, "zones", {{Rect(100, 100, 200, 200)}}).ok());
  o.nofly = {dir + "/zones.gpkg"};
  auto map = ImportMap(o);
  ASSERT_TRUE(map.ok()) << map.status();
  // Cells 10..19 and the ones the edges touch: 10..20 (GDAL's ALL_TOUCHED).
  EXPECT_GE(map->stats.nofly_cells, 100);
  EXPECT_LE(map->stats.nofly_cells, 121);
  EXPECT_EQ(map->layers.nofly[15 * 200 + 15], 1);
  EXPECT_EQ(map->layers.nofly[25 * 200 + 25], 0);

  // A hospital as a point, with 200 m around it.
  ASSERT_TRUE(WriteVector(dir + "/hospital.geojson", "GeoJSON", "EPSG:4326", "hospital",
                          {{absl::StrFormat("POINT (%.7f %.7f)", kLon, kLat)}})
                  .ok());
  o.nofly = {dir + "/hospital.geojson"};
  EXPECT_THAT(ImportMap(o).status().message(),
              HasSubstr("feature 0 is a Point, which encloses no area; give --nofly_buffer_m"));
  o.nofly_buffer_m = 200.0;
  map = ImportMap(o);
  ASSERT_TRUE(map.ok()) << map.status();
  const double disc = M_PI * 200.0 * 200.0 / 100.0;
  EXPECT_GT(map->stats.nofly_cells, disc);
  EXPECT_LT(map->stats.nofly_cells, M_PI * 215.0 * 215.0 / 100.0);
  // A zone 100 m beyond the map's west edge reaches 100 m into it once
  // buffered by 200 m.
  ASSERT_TRUE(
      WriteVector(dir + "/outside.gpkg", "GPKG", frame, "zones", {{Rect(-300, 900, -100, 1100)}})
          .ok());
  o.nofly = {dir + "/outside.gpkg"};
  map = ImportMap(o);
  ASSERT_TRUE(map.ok()) << map.status();
  EXPECT_EQ(map->layers.nofly[100 * 200 + 5], 1);
  EXPECT_EQ(map->layers.nofly[100 * 200 + 12], 0);
}

// Landing sites from points and polygons (named by a field), from the land
// cover's open fields, and never in a no-fly cell.
TEST(ImportInputsTest, LandingSites) {
  const std::string dir = FreshDir("landing");
  ImportOptions o = MapOptions(dir);
  const std::string frame = FrameCrs(o);
  ASSERT_TRUE(WriteVector(dir + "/sites.gpkg", "GPKG", frame, "sites",
                          {{"POINT (1005 1005)", {}, {{"name", "square"}}},
                           {"POINT (1505 1505)", {}, {{"name", "in-nofly"}}},
                           {"POINT (5000 5000)", {}, {{"name", "far-away"}}},
                           {Rect(200, 1200, 400, 1300), {}, {{"name", "park"}}}})
                  .ok());
  ASSERT_TRUE(WriteVector(dir + "/zones.gpkg", "GPKG", frame, "zones",
                          {{Rect(1450, 1450, 1550, 1550)}, {Rect(200, 1200, 280, 1300)}})
                  .ok());
  o.landing = {dir + "/sites.gpkg"};
  o.landing_name_field = "name";
  o.nofly = {dir + "/zones.gpkg"};
  auto map = ImportMap(o);
  ASSERT_TRUE(map.ok()) << map.status();
  ASSERT_EQ(map->layers.landing_sites.size(), 2u);
  EXPECT_EQ(map->layers.landing_sites[0].name, "square");
  EXPECT_EQ(map->layers.landing_sites[0].i, 100);
  EXPECT_EQ(map->layers.landing_sites[0].j, 100);
  // The park's cells 20..39 x 120..129, less the no-fly part (x < 280 m,
  // and the cells it touches): its deepest free cell.
  EXPECT_EQ(map->layers.landing_sites[1].name, "park");
  EXPECT_GE(map->layers.landing_sites[1].i, 31);
  EXPECT_LE(map->layers.landing_sites[1].i, 34);
  EXPECT_GE(map->layers.landing_sites[1].j, 123);
  EXPECT_LE(map->layers.landing_sites[1].j, 126);
  EXPECT_EQ(map->stats.landing_dropped_nofly, 1);
  for (const LandingSite& s : map->layers.landing_sites) {
    EXPECT_EQ(map->layers.nofly[static_cast<size_t>(s.j) * 200 + s.i], 0) << s.name;
  }
  bool noted = false;
  for (const std::string& n : map->notes) noted |= n.find("in-nofly") != std::string::npos;
  EXPECT_TRUE(noted);

  // Open fields of the land cover: a 300 m x 300 m grassland in trees is a
  // site at its middle; a 100 m x 100 m one is too small for 20000 m^2.
  auto c = testing::Carry("EPSG:4326", "EPSG:32632", kLon, kLat);
  RasterSpec s;
  s.srs = "EPSG:32632";
  s.type = GDT_Byte;
  s.width = s.height = 300;
  const double e0 = std::floor(c->first) - 1500, n0 = std::floor(c->second) + 1500;
  s.geotransform[0] = e0;
  s.geotransform[1] = 10;
  s.geotransform[3] = n0;
  s.geotransform[5] = -10;
  s.values.assign(300 * 300, 10);
  for (int r = 120; r < 150; ++r) {
    for (int col = 120; col < 150; ++col) s.values[static_cast<size_t>(r) * 300 + col] = 30;
  }
  for (int r = 200; r < 210; ++r) {
    for (int col = 200; col < 210; ++col) s.values[static_cast<size_t>(r) * 300 + col] = 40;
  }
  ASSERT_TRUE(WriteRaster(dir + "/lc.tif", s).ok());
  o.landing.clear();
  o.nofly.clear();
  o.landcover = dir + "/lc.tif";
  o.landing_min_area_m2 = 20000.0;
  map = ImportMap(o);
  ASSERT_TRUE(map.ok()) << map.status();
  ASSERT_EQ(map->layers.landing_sites.size(), 1u);
  auto centre = testing::Carry("EPSG:32632", "EPSG:4326", e0 + 1350, n0 - 1350);
  auto [ci, cj] = CellOfLatLon(*map, centre->second, centre->first);
  EXPECT_NEAR(map->layers.landing_sites[0].i, ci, 2);
  EXPECT_NEAR(map->layers.landing_sites[0].j, cj, 2);
  EXPECT_EQ(map->layers.landing_sites[0].name, "field-1");
  EXPECT_EQ(map->stats.landing_from_landcover, 1);
  o.landing_min_area_m2 = 5000.0;
  map = ImportMap(o);
  ASSERT_TRUE(map.ok()) << map.status();
  EXPECT_EQ(map->layers.landing_sites.size(), 2u);

  // Lines are neither.
  ASSERT_TRUE(
      WriteVector(dir + "/road.gpkg", "GPKG", frame, "road", {{"LINESTRING (0 0, 100 100)"}}).ok());
  o.landing = {dir + "/road.gpkg"};
  o.landing_name_field.clear();
  EXPECT_THAT(ImportMap(o).status().message(),
              HasSubstr("feature 1 is a Line String; landing sites are points or polygons"));
}

TEST(ImportInputsTest, BadInputsAreRefusedNamingLayerAndInput) {
  const std::string dir = FreshDir("bad-inputs");
  ImportOptions o = MapOptions(dir);
  o.population = dir + "/missing.tif";
  const absl::Status missing = ImportMap(o).status();
  EXPECT_EQ(missing.code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(missing.message(), HasSubstr("layer 'population', input '" + dir +
                                           "/missing.tif': cannot read it: No such file or "
                                           "directory"));
  o.population = "";
  o.nofly = {dir + "/flat.tif|layername=zones"};
  EXPECT_THAT(ImportMap(o).status().message(), HasSubstr("layer 'no-fly', input '" + dir +
                                                         "/flat.tif': GDAL cannot open it as a "
                                                         "vector source"));
  ASSERT_TRUE(WriteVector(dir + "/z.gpkg", "GPKG", "EPSG:4326", "zones", {}).ok());
  o.nofly = {dir + "/z.gpkg|layername=airports"};
  EXPECT_THAT(ImportMap(o).status().message(), HasSubstr("no layer 'airports'; it has: zones"));
  o.nofly = {dir + "/z.gpkg|layer=zones"};
  EXPECT_THAT(ImportMap(o).status().message(), HasSubstr("unknown option 'layer=zones'"));
  o.nofly = {dir + "/z.gpkg|where=nonsense ==="};
  // (GeoPackage checks the filter when the features are read.)
  EXPECT_THAT(ImportMap(o).status().message(), HasSubstr("layer 'no-fly', input '" + dir +
                                                         "/z.gpkg' (layer 'zones'): reading its "
                                                         "features failed"));
  o.nofly.clear();
  o.terrain = "/vsicurl/https://example.org/dem.tif";
  EXPECT_THAT(ImportMap(o).status().message(), HasSubstr("not a local file"));
  // A raster without a CRS (an ASCII grid without its .prj).
  std::ofstream(dir + "/nocrs.asc") << "ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n"
                                       "1 2\n3 4\n";
  o.terrain = dir + "/nocrs.asc";
  EXPECT_THAT(ImportMap(o).status().message(),
              HasSubstr("layer 'terrain', input '" + dir + "/nocrs.asc': the raster has no CRS"));
  o.terrain = "";
  EXPECT_THAT(ImportMap(o).status().message(), HasSubstr("--terrain=DEM is required"));
  o = MapOptions(dir);
  o.name = "Bad Name";
  EXPECT_THAT(ImportMap(o).status().message(), HasSubstr("--name: map header: name 'Bad Name'"));
}

// Found by fuzz/geo_import_fuzz.cc: a no-fly polygon in WGS84 with one wrong
// vertex (longitude 642, latitude 5919.61; the others on the map) was cut into 5.9 million pieces of
// 0.001 degrees before PROJ refused every one of them, and the capture kept
// every refusal's message: 1 GB for one feature of 300 bytes. The pieces are
// now counted, against a budget per input, before any is made, and the
// capture keeps 16 messages.
TEST(ImportInputsTest, AWrongCoordinateIsRefusedBeforeItsEdgesAreCut) {
  const std::string dir = FreshDir("wrong-coordinate");
  ImportOptions o = MapOptions(dir);
  ASSERT_TRUE(WriteVector(dir + "/zones.geojson", "GeoJSON", "EPSG:4326", "zones",
                          {{"POLYGON ((642 5919.61, 6.1 49.6, 6.101 49.6, 6.1 49.601, "
                            "642 5919.61))"}})
                  .ok());
  o.nofly = {dir + "/zones.geojson"};
  const absl::Status refused = ImportMap(o).status();
  EXPECT_EQ(refused.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(refused.message()),
              HasSubstr("feature 0: cutting its edges into pieces of at most 0.001 degrees for "
                        "the change of CRS would add 1.181e+07 vertices, more than the 4000000 "
                        "left of the 4000000 the importer allows one input's features"));
  EXPECT_THAT(std::string(refused.message()), HasSubstr("check its coordinates"));

  // In metres: an easting of 1e12 m in the map's own frame.
  const std::string frame = FrameCrs(o);
  ASSERT_TRUE(WriteVector(dir + "/far.gpkg", "GPKG", frame, "zones",
                          {{Rect(100, 100, 200, 200)}, {Rect(100, 300, 1e12, 400)}})
                  .ok());
  o.nofly = {dir + "/far.gpkg"};
  EXPECT_THAT(std::string(ImportMap(o).status().message()),
              HasSubstr("feature 2: cutting its edges into pieces of at most 100 m for the "
                        "change of CRS would add 2e+10 vertices"));

  // Within the budget, a polygon reaching past the pole: PROJ refuses
  // thousands of its points, and the message keeps 16 of their reasons.
  ASSERT_TRUE(WriteVector(dir + "/pole.geojson", "GeoJSON", "EPSG:4326", "zones",
                          {{"POLYGON ((6.1 49.6, 6.101 49.6, 6.101 95, 6.1 49.6))"}})
                  .ok());
  o.nofly = {dir + "/pole.geojson"};
  const absl::Status pole = ImportMap(o).status();
  EXPECT_EQ(pole.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(pole.message()), HasSubstr("feature 0: PROJ cannot carry it into the map's frame"));
  EXPECT_LT(pole.message().size(), 20000u) << pole.message().substr(0, 2000);
}

TEST(ImportInputsTest, VerticesAddedBySegmentizeCountsEveryEdge) {
  const auto added = [](const char* wkt, double step) {
    OGRGeometry* g = nullptr;
    EXPECT_EQ(OGRGeometryFactory::createFromWkt(wkt, nullptr, &g), OGRERR_NONE) << wkt;
    const double n = VerticesAddedBySegmentize(*g, step);
    // An upper bound of what segmentize really adds (GDAL 3.6 adds
    // floor(length / step - 0.01) to an edge), at most one more an edge.
    if (std::isfinite(n) && wkbFlatten(g->getGeometryType()) == wkbLineString) {
      std::unique_ptr<OGRGeometry> cut(g->clone());
      cut->segmentize(step);
      const int points = g->toLineString()->getNumPoints();
      const int real = cut->toLineString()->getNumPoints() - points;
      EXPECT_GE(n, real) << wkt;
      EXPECT_LE(n, real + points - 1) << wkt;
    }
    OGRGeometryFactory::destroyGeometry(g);
    return n;
  };
  EXPECT_EQ(added("LINESTRING (0 0, 250 0)", 100.0), 2.0);
  EXPECT_EQ(added("LINESTRING (0 0, 1000 0, 1000 1000.5)", 100.0), 9.0 + 10.0);
  EXPECT_EQ(added("LINESTRING (0 0, 100 0, 100 50)", 100.0), 0.0);
  EXPECT_EQ(added("POINT (1 2)", 100.0), 0.0);
  // A 300 m square with a 150 m square hole: 4 x 2 + 4 x 1.
  EXPECT_EQ(added("POLYGON ((0 0, 300 0, 300 300, 0 300, 0 0), (10 10, 160 10, 160 160, 10 160, "
                  "10 10))",
                  100.0),
            12.0);
  EXPECT_EQ(added("MULTIPOLYGON (((0 0, 250 0, 0 1, 0 0)), ((0 0, 0 250, 1 0, 0 0)))", 100.0),
            2.0 + 2.0 + 2.0 + 2.0);
  EXPECT_EQ(added("LINESTRING (0 0, 1e300 0)", 1e-300), std::numeric_limits<double>::infinity());
}

TEST(ImportInputsTest, TheCaptureKeepsSixteenMessagesAndCountsTheRest) {
  GdalErrorCapture capture;
  for (int k = 0; k < 1000; ++k) CPLError(CE_Failure, CPLE_AppDefined, "failure %d", k);
  for (int k = 0; k < 40; ++k) CPLError(CE_Warning, CPLE_AppDefined, "warning %d", k);
  EXPECT_EQ(capture.error_count(), 1000u);
  EXPECT_EQ(capture.warning_count(), 40u);
  EXPECT_EQ(capture.warnings().size(), GdalErrorCapture::kMaxMessages);
  const std::string errors = capture.Errors();
  EXPECT_THAT(errors, HasSubstr("failure 0; failure 1; "));
  EXPECT_THAT(errors, HasSubstr("failure 15; and 984 more"));
  EXPECT_THAT(errors, ::testing::Not(HasSubstr("failure 16")));
}

// Found by fuzz/geo_import_fuzz.cc: a path that is not UTF-8 (a Latin-1 file
// name) made the provenance's JSON library throw out of ImportMap, so that
// riskplan-tool import died of an uncaught exception. The bytes it cannot
// carry become U+FFFD; the import succeeds.
TEST(ImportInputsTest, PathsThatAreNotUtf8KeepTheProvenanceValidJson) {
  const std::string dir = FreshDir("latin1");
  ImportOptions o = MapOptions(dir);
  const std::string latin1 = dir + "/flat-caf\xe9.tif";
  ASSERT_EQ(std::rename(o.terrain.c_str(), latin1.c_str()), 0);
  o.terrain = latin1;
  o.command_line = "riskplan-tool import --terrain=flat-caf\xe9.tif";
  auto map = ImportMap(o);
  ASSERT_TRUE(map.ok()) << map.status();
  const nlohmann::json p = nlohmann::json::parse(map->provenance_json);
  EXPECT_EQ(p["inputs"][0]["path"], dir + "/flat-caf\xef\xbf\xbd.tif");
  EXPECT_EQ(p["command"], "riskplan-tool import --terrain=flat-caf\xef\xbf\xbd.tif");
}

}  // namespace
}  // namespace riskplan::geo
