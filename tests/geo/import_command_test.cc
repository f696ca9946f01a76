// `riskplan-tool import` end to end: the real binary on inputs GDAL wrote.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "core/map/map_bundle.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/geo/geodata_fixtures.h"
#include "tests/integration/server_process.h"

namespace riskplan::geo {
namespace {

using ::riskplan::testing::RunCommand;
using testing::FreshDir;
using ::testing::HasSubstr;
using ::testing::Not;
using testing::RasterSpec;

::riskplan::testing::CommandResult Tool(const std::string& args) {
  return RunCommand(std::string(RISKPLAN_BIN_DIR) + "/riskplan-tool " + args + " 2>&1");
}

std::string Dem(const std::string& dir, double west, double south, double size_deg) {
  RasterSpec s;
  s.srs = "EPSG:4326";
  s.width = s.height = static_cast<int>(std::lround(size_deg / 0.001));
  s.geotransform[0] = west;
  s.geotransform[1] = 0.001;
  s.geotransform[3] = south + size_deg;
  s.geotransform[5] = -0.001;
  s.values.assign(static_cast<size_t>(s.width) * s.height, 320.0);
  s.type = GDT_Int16;
  s.has_nodata = true;
  s.nodata = -32768;
  EXPECT_TRUE(testing::WriteRaster(dir + "/dem.tif", s).ok());
  return dir + "/dem.tif";
}

TEST(ImportCommandTest, HelpListsTheFlags) {
  const auto r = Tool("import --help");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  for (const char* flag :
       {"out", "center", "bbox", "size_m", "res_m", "terrain", "population", "population_unit",
        "population_field", "landcover", "buildings", "nofly", "nofly_buffer_m", "landing",
        "landing_min_area_m2", "fill_terrain", "fill_density", "fill_shelter", "threads"}) {
    EXPECT_THAT(r.output, HasSubstr(absl::StrFormat("\n  --%s=", flag))) << flag;
  }
  EXPECT_THAT(r.output, Not(HasSubstr("--seed=")));
  // Prose fits a terminal; synopses and examples are indented.
  for (absl::string_view line : absl::StrSplit(r.output, '\n')) {
    if (!absl::StartsWith(line, " ")) {
      EXPECT_LE(line.size(), 80u) << line;
    }
  }
  EXPECT_THAT(Tool("--help").output, HasSubstr("\n  import "));
}

TEST(ImportCommandTest, WritesABundleWithItsProvenance) {
  const std::string dir = FreshDir("command");
  const std::string dem = Dem(dir, 6.05, 49.55, 0.1);
  ASSERT_TRUE(testing::WriteVector(dir + "/sites.geojson", "GeoJSON", "EPSG:4326", "sites",
                                   {{"POINT (6.1 49.6)", {}, {{"name", "centre"}}}})
                  .ok());
  const std::string out = dir + "/maps/test-town";
  const std::string args = absl::StrFormat(
      "import --out=%s --center=49.6,6.1 --size_m=2000 --res_m=10 --terrain=%s "
      "--landing=%s/sites.geojson --landing_name_field=name",
      out, dem, dir);
  auto r = Tool(args);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("map           test-town: 200 x 200 cells of 10 m"));
  EXPECT_THAT(r.output, HasSubstr("landing sites 1"));
  auto map = LoadMapBundle(out);
  ASSERT_TRUE(map.ok()) << map.status();
  EXPECT_EQ((*map)->name(), "test-town");
  ASSERT_TRUE((*map)->header().geo.has_value());
  EXPECT_NEAR((*map)->header().geo->origin_lat_deg, 49.6 - 1000 / 111'200.0, 1e-4);
  EXPECT_THAT((*map)->header().geo->crs, HasSubstr("+proj=aeqd"));
  EXPECT_THAT((*map)->header().provenance,
              HasSubstr("terrain from '" + dem + "' (GTiff, EPSG:4326)"));
  EXPECT_THAT((*map)->header().provenance, HasSubstr("command: "));
  EXPECT_EQ((*map)->terrain(50, 50), 320.0f);
  std::ifstream in(out + "/manifest.json");
  const nlohmann::json manifest = nlohmann::json::parse(in);
  const nlohmann::json& p = manifest["x_import"];
  EXPECT_THAT(p["command"].get<std::string>(), HasSubstr("riskplan-tool import --out="));
  ASSERT_EQ(p["inputs"].size(), 2u);
  EXPECT_EQ(p["inputs"][0]["layer"], "terrain");
  EXPECT_EQ(p["inputs"][0]["crs"], "EPSG:4326");
  EXPECT_THAT(p["inputs"][0]["crs_wkt"].get<std::string>(), HasSubstr("GEOGCRS[\"WGS 84\""));
  EXPECT_THAT(p["inputs"][0]["detail"].get<std::string>(), HasSubstr("nodata value -32768"));
  EXPECT_EQ(p["inputs"][1]["layer"], "landing sites");
  EXPECT_THAT(p["frame"]["definition"].get<std::string>(), HasSubstr("+proj=aeqd"));

  // Again over the same bundle: replaced.
  r = Tool(args + " --base_shelter=4");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  map = LoadMapBundle(out);
  ASSERT_TRUE(map.ok()) << map.status();
  EXPECT_EQ((*map)->shelter(0, 0), 4.0f);
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir + "/maps"),
                          std::filesystem::directory_iterator()),
            1);
  // `info` reads it and gives its reach.
  r = Tool("info --map=" + out);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("impact reach"));
}

TEST(ImportCommandTest, RefusalsExitTwoAndWriteNothing) {
  const std::string dir = FreshDir("command-refusal");
  const std::string dem = Dem(dir, 6.05, 49.55, 0.04);  // ends 0.01 deg west of the map's east edge
  const std::string out = dir + "/maps/refused";
  auto r = Tool(absl::StrFormat(
      "import --out=%s --center=49.6,6.1 --size_m=2000 --res_m=10 --terrain=%s", out, dem));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("riskplan-tool: layer 'terrain', input '" + dem + "': "));
  EXPECT_THAT(r.output, HasSubstr("outside the input's extent"));
  EXPECT_FALSE(std::filesystem::exists(out));
  EXPECT_FALSE(std::filesystem::exists(dir + "/maps") && !std::filesystem::is_empty(dir + "/maps"));
  r = Tool(absl::StrFormat("import --out=%s --terrain=%s", out, dem));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.output, HasSubstr("give the area as --center=LAT,LON"));
  r = Tool(absl::StrFormat("import --out=%s --bbox=49.6,6.1 --terrain=%s", out, dem));
  EXPECT_THAT(r.output, HasSubstr("--bbox='49.6,6.1': expected 4 comma-separated numbers"));
  r = Tool(absl::StrFormat(
      "import --out=%s --center=49.6,6.1 --terrain=%s --population_unit=per_ha", out, dem));
  EXPECT_THAT(r.output, HasSubstr("--population_unit='per_ha'"));
  // A directory that is not a bundle is never replaced.
  std::filesystem::create_directories(dir + "/precious");
  std::ofstream(dir + "/precious/notes.txt") << "keep me\n";
  const std::string big_dem = Dem(dir, 6.0, 49.5, 0.2);
  r = Tool(absl::StrFormat(
      "import --out=%s/precious --center=49.6,6.1 --size_m=1000 --res_m=10 --terrain=%s", dir,
      big_dem));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_THAT(r.output, HasSubstr("is a directory without manifest.json; not replacing it"));
  EXPECT_TRUE(std::filesystem::exists(dir + "/precious/notes.txt"));
}

// What GDAL or the system says reaches the message, in their own words: a
// missing file is NotFound (exit 1) with the system's reason, a truncated
// GeoTIFF fails the warp (whose source is read on GDAL's own thread, -multi)
// with libtiff's reason, not "no message from GDAL", and nothing of it goes
// to stderr past the message.
TEST(ImportCommandTest, MissingAndTruncatedInputsFailWithTheirOwnReasons) {
  const std::string dir = FreshDir("command-gdal-reasons");
  const std::string out = dir + "/maps/town";
  const std::string missing = dir + "/no-such-dem.tif";
  auto r = Tool(absl::StrFormat(
      "import --out=%s --center=49.6,6.1 --size_m=2000 --res_m=10 --terrain=%s", out, missing));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_EQ(r.output, "riskplan-tool: layer 'terrain', input '" + missing +
                          "': cannot read it: No such file or directory\n");

  const std::string dem = Dem(dir, 6.0, 49.5, 0.2);
  const auto size = std::filesystem::file_size(dem);
  std::filesystem::resize_file(dem, size / 2);
  r = Tool(absl::StrFormat(
      "import --out=%s --center=49.6,6.1 --size_m=2000 --res_m=10 --terrain=%s", out, dem));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("riskplan-tool: layer 'terrain', input '" + dem + "': "));
  EXPECT_THAT(r.output, Not(HasSubstr("no message from GDAL")));
  EXPECT_THAT(r.output, HasSubstr("TIFFRead"));
  // One line: GDAL's words are in the message, none printed beside it.
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  EXPECT_FALSE(std::filesystem::exists(out));
}

// A disk that fills up during the write (here a file size limit, which root
// is subject to too): the import says which file, exits 1, and the bundle
// already at --out is left whole, with no temporary directory beside it.
TEST(ImportCommandTest, AFailedWriteLeavesTheOldBundleWhole) {
  const std::string dir = FreshDir("command-full-disk");
  const std::string dem = Dem(dir, 6.0, 49.5, 0.2);
  const std::string out = dir + "/maps/town";
  const std::string args = absl::StrFormat(
      "import --out=%s --center=49.6,6.1 --size_m=2000 --res_m=10 --terrain=%s", out, dem);
  ASSERT_EQ(Tool(args).exit_code, 0);
  std::ifstream in(out + "/manifest.json");
  const std::string before((std::istreambuf_iterator<char>(in)), {});
  // 16 blocks of at most 1 KiB; each layer file is 160 000 bytes.
  const auto r = RunCommand("ulimit -f 16 && exec " + std::string(RISKPLAN_BIN_DIR) +
                            "/riskplan-tool " + args + " --base_shelter=4 2>&1");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_THAT(r.output, HasSubstr("cannot write '" + out + "/density.f32': File too large"));
  std::ifstream again(out + "/manifest.json");
  EXPECT_EQ(std::string((std::istreambuf_iterator<char>(again)), {}), before);
  auto map = LoadMapBundle(out);
  ASSERT_TRUE(map.ok()) << map.status();
  EXPECT_EQ((*map)->shelter(0, 0), 2.5f) << "the old bundle's shelter (--base_shelter's default)";
  std::vector<std::string> entries;
  for (const auto& e : std::filesystem::directory_iterator(dir + "/maps")) {
    entries.push_back(e.path().filename());
  }
  EXPECT_THAT(entries, ::testing::ElementsAre("town"));
}

}  // namespace
}  // namespace riskplan::geo
