// riskplan-tool end to end: the real binary on a bundle it wrote itself.
#include <png.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "core/base/geometry.h"
#include "core/flight/trajectory.h"
#include "core/map/map_bundle.h"
#include "core/risk/risk_model.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/child_process.h"

namespace riskplan {
namespace {

using ::testing::HasSubstr;

struct Output {
  int exit_code = -1;
  std::string text;  // stdout and stderr
};

Output RunTool(const std::string& args) {
  const testing::CommandResult r =
      testing::RunCommand(std::string(RISKPLAN_BIN_DIR) + "/riskplan-tool " + args + " 2>&1");
  return Output{r.exit_code, r.output};
}

// An ESRI ASCII grid as written: its six header fields and its rows, south first.
struct AsciiGrid {
  std::map<std::string, double> header;
  std::vector<std::vector<double>> rows;  // rows[r][c], r = 0 south
};

AsciiGrid ReadAsciiGrid(const std::string& path) {
  AsciiGrid grid;
  std::ifstream in(path);
  std::vector<std::string> keys;
  for (int k = 0; k < 6; ++k) {
    std::string key;
    double value = 0.0;
    in >> key >> value;
    keys.push_back(key);
    grid.header[key] = value;
  }
  EXPECT_EQ(keys, (std::vector<std::string>{"ncols", "nrows", "xllcorner", "yllcorner", "cellsize",
                                            "NODATA_value"}));
  const int ncols = static_cast<int>(grid.header["ncols"]);
  const int nrows = static_cast<int>(grid.header["nrows"]);
  grid.rows.assign(nrows, std::vector<double>(ncols));
  for (int r = nrows - 1; r >= 0; --r) {
    for (int c = 0; c < ncols; ++c) in >> grid.rows[r][c];
  }
  EXPECT_FALSE(in.fail()) << path;
  double extra = 0.0;
  EXPECT_FALSE(in >> extra) << path << " has more values than ncols * nrows";
  return grid;
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// PARAMETER["name",value] of a WKT1 string; NaN when missing.
double WktParameter(const std::string& wkt, const std::string& name) {
  std::smatch m;
  if (!std::regex_search(wkt, m, std::regex("PARAMETER\\[\"" + name + "\",([^\\]]+)\\]"))) {
    return std::nan("");
  }
  return std::stod(m[1].str());
}

// The PNG as 8-bit RGB, north row first; empty on failure.
std::vector<png_byte> ReadPngRgb(const std::string& path, int* width, int* height) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&image, path.c_str())) return {};
  image.format = PNG_FORMAT_RGB;
  std::vector<png_byte> rgb(PNG_IMAGE_SIZE(image));
  if (!png_image_finish_read(&image, nullptr, rgb.data(), 0, nullptr)) return {};
  *width = static_cast<int>(image.width);
  *height = static_cast<int>(image.height);
  return rgb;
}

class RiskplanToolTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // One directory per process: CTest runs the tests of this file in parallel.
    dir_ =
        new std::string(::testing::TempDir() + "/riskplan_tool_test." + std::to_string(getpid()));
    std::filesystem::remove_all(*dir_);
    std::filesystem::create_directories(*dir_);
    const Output written = RunTool("write-map --out=" + *dir_ + "/city --size_m=1000 --res_m=10");
    ASSERT_EQ(written.exit_code, 0) << written.text;
    ASSERT_THAT(written.text, HasSubstr("wrote demo-city (100 x 100 cells"));
    ASSERT_TRUE(WriteMapBundle(*GeoMap(kLatDeg, kLonDeg), *dir_ + "/geo").ok());
    ASSERT_TRUE(WriteMapBundle(*GeoMap(95.0, kLonDeg), *dir_ + "/bad-geo").ok());
  }

  static void TearDownTestSuite() {
    std::error_code ec;
    std::filesystem::remove_all(*dir_, ec);
    delete dir_;
    dir_ = nullptr;
  }

  static constexpr double kLatDeg = 50.0875;
  static constexpr double kLonDeg = 14.4213;

  // 30 x 20 cells of 10 m with its origin at (1000, -500), a geo-reference,
  // layers that change from cell to cell (no people from column 20 east), and
  // the western five columns 1e6 m high: there, 1e6 + 1e-11 rounds to 1e6, so
  // --agl_m=1e-11 leaves M undefined.
  static std::shared_ptr<const RiskMap> GeoMap(double lat_deg, double lon_deg) {
    MapHeader header;
    header.name = "geo-test";
    header.x0 = 1000.0;
    header.y0 = -500.0;
    header.res = 10.0;
    header.nx = 30;
    header.ny = 20;
    header.geo = GeoReference{lat_deg, lon_deg, "local ENU tangent plane"};
    MapLayers layers;
    for (int j = 0; j < header.ny; ++j) {
      for (int i = 0; i < header.nx; ++i) {
        layers.density.push_back(i >= 20 ? 0.0f : 0.002f * ((i * 7 + j * 13) % 11));
        layers.shelter.push_back(static_cast<float>((i * 3 + j * 5) % 10));
        layers.terrain.push_back(i < 5 ? 1.0e6f : 150.0f + 4.0f * ((i + 2 * j) % 5));
        layers.nofly.push_back(0);
      }
    }
    auto map = RiskMap::Create(std::move(header), std::move(layers));
    EXPECT_TRUE(map.ok()) << map.status();
    return *map;
  }
  static std::string* dir_;
};
std::string* RiskplanToolTest::dir_ = nullptr;

TEST_F(RiskplanToolTest, InfoDescribesTheBundle) {
  const Output out = RunTool("info --map=" + *dir_ + "/city");
  ASSERT_EQ(out.exit_code, 0) << out.text;
  EXPECT_THAT(out.text, HasSubstr("100 x 100 cells of 10 m"));
  EXPECT_THAT(out.text, HasSubstr("demo-city"));
}

// write-map on a disk that fills up (here: a file size limit, which root
// is subject to as well; the tool ignores SIGXFSZ, so the write fails with
// EFBIG instead of killing it): it says which file, exits 1, and leaves no
// bundle and no temporary directory. A bundle already at --out is replaced
// whole, as import does; a directory of other things is left alone.
TEST_F(RiskplanToolTest, WriteMapFailsCleanlyAndReplacesOnlyABundle) {
  // Normalised, as the tool names it ("/tmp/" + "/..." has a double slash).
  const std::string parent = std::filesystem::path(*dir_ + "/write-map").lexically_normal();
  std::filesystem::create_directories(parent);
  const std::string out = parent + "/city";
  const std::string write = "write-map --out=" + out + " --size_m=1000 --res_m=10";
  // 16 blocks of at most 1 KiB: each layer file is 40 000 bytes.
  const testing::CommandResult limited =
      testing::RunCommand("ulimit -f 16 && exec " + std::string(RISKPLAN_BIN_DIR) +
                          "/riskplan-tool " + write + " 2>&1");
  EXPECT_EQ(limited.exit_code, 1) << limited.output;
  EXPECT_THAT(limited.output, HasSubstr("cannot write '" + out + "/density.f32': File too large"));
  EXPECT_TRUE(std::filesystem::is_empty(parent)) << "a bundle or a temporary directory is left";

  Output r = RunTool(write);
  ASSERT_EQ(r.exit_code, 0) << r.text;
  const std::string before = ReadFile(out + "/manifest.json");
  r = RunTool(write + " --seed=2");
  ASSERT_EQ(r.exit_code, 0) << r.text;
  // Another city: other checksums in the manifest.
  EXPECT_TRUE(ReadFile(out + "/manifest.json") != before) << "the bundle was not replaced";
  int entries = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(parent)) ++entries;
  EXPECT_EQ(entries, 1);

  const std::string other = parent + "/other";
  std::filesystem::create_directories(other);
  std::ofstream(other + "/README") << "not a map";
  r = RunTool("write-map --out=" + other + " --size_m=1000 --res_m=10");
  EXPECT_EQ(r.exit_code, 1) << r.text;
  EXPECT_THAT(r.text, HasSubstr("'" + other + "' is a directory without manifest.json"));
  EXPECT_EQ(ReadFile(other + "/README"), "not a map");
}

TEST_F(RiskplanToolTest, EvaluatePrintsWhatTheLibraryComputes) {
  auto map = LoadMapBundle(*dir_ + "/city");
  ASSERT_TRUE(map.ok()) << map.status();
  auto model = RiskModel::Create(*map, ModelParams{});
  ASSERT_TRUE(model.ok());
  int i = 0;
  int j = 0;
  ASSERT_TRUE((*map)->CellOf(300, 300, &i, &j));
  const double z = (*model)->SafeAltitude(i, j) + 20.0;
  const std::string polyline = "300,300," + std::to_string(z) + ";700,650," + std::to_string(z);
  const Output out =
      RunTool("evaluate --json --samples --map=" + *dir_ + "/city --polyline='" + polyline + "'");
  ASSERT_EQ(out.exit_code, 0) << out.text;
  const nlohmann::json doc = nlohmann::json::parse(out.text);
  auto pieces = PiecesFromPolyline(std::vector<Point3>{{300, 300, z}, {700, 650, z}});
  ASSERT_TRUE(pieces.ok());
  auto eval = EvaluateTrajectory(**model, *pieces, {.keep_samples = true});
  ASSERT_TRUE(eval.ok());
  EXPECT_EQ(doc["risk"].get<double>(), eval->risk);  // JSON round-trips doubles exactly
  EXPECT_EQ(doc["length_m"].get<double>(), eval->length_m);
  EXPECT_EQ(doc["admissible"].get<bool>(), eval->admissible);
  ASSERT_EQ(doc["samples"].size(), eval->samples.size());
  EXPECT_EQ(doc["samples"][7]["M"].get<double>(), eval->samples[7].risk.risk);
  EXPECT_EQ(doc["samples"][7]["arc_length_m"].get<double>(), eval->samples[7].arc_length_m);

  const Output text = RunTool("evaluate --map=" + *dir_ + "/city --waypoints='300,300," +
                              std::to_string(z) + ",0; 700,650," + std::to_string(z) + ",1.2'");
  ASSERT_EQ(text.exit_code, 0) << text.text;
  EXPECT_THAT(text.text, HasSubstr("1 Dubins-airplane pieces"));
  EXPECT_THAT(text.text, HasSubstr("admissible"));
}

TEST_F(RiskplanToolTest, EvaluateReportsTheFirstViolation) {
  const Output out =
      RunTool("evaluate --map=" + *dir_ + "/city --polyline='500,500,50;600,500,50'");
  ASSERT_EQ(out.exit_code, 0) << out.text;
  EXPECT_THAT(out.text, HasSubstr("admissible  no"));
  EXPECT_THAT(out.text, HasSubstr("TERRAIN_COLLISION at (500.0, 500.0, 50.0) m, arc length 0.0 m"));
}

TEST_F(RiskplanToolTest, BadInputGetsAClearErrorAndExitCode2) {
  Output out = RunTool("evaluate --polyline='1,2,3;4,5,6' --waypoints='1,2,3,4;5,6,7,8'");
  EXPECT_EQ(out.exit_code, 2);
  EXPECT_THAT(out.text,
              HasSubstr("give exactly one of --waypoints, --polyline and --trajectory_file"));
  out = RunTool("evaluate --map=" + *dir_ + "/city --polyline='1,2,3;4,x,6'");
  EXPECT_EQ(out.exit_code, 2);
  EXPECT_THAT(out.text, HasSubstr("polyline[1]: 'x' is not a number"));
  out = RunTool("evaluate --map=" + *dir_ + "/city --params=mass_kg=-3 --polyline='1,2,3;4,5,6'");
  EXPECT_EQ(out.exit_code, 2);
  EXPECT_THAT(out.text, HasSubstr("mass_kg"));
  out = RunTool("evaluate --map=" + *dir_ + "/nowhere --polyline='1,2,3;4,5,6'");
  EXPECT_NE(out.exit_code, 0);
  EXPECT_THAT(out.text, HasSubstr("nowhere"));
  out = RunTool("frobnicate");
  EXPECT_EQ(out.exit_code, 2);
  EXPECT_THAT(out.text, HasSubstr("unknown command 'frobnicate'"));
}

TEST_F(RiskplanToolTest, RiskLayerGridAndProjectionPutEveryValueWhereItWasComputed) {
  const std::string prefix = *dir_ + "/geo-layer";
  const Output out = RunTool("risk-layer --map=" + *dir_ + "/geo --out=" + prefix +
                             " --agl_m=30 --heading_deg=30 --stride=2 --threads=2");
  ASSERT_EQ(out.exit_code, 0) << out.text;
  EXPECT_THAT(out.text, HasSubstr("15 x 10 cells of 20 m at 30 m AGL, heading 30 deg"));
  EXPECT_THAT(out.text, HasSubstr("wrote " + prefix + ".png, " + prefix + ".asc and " + prefix +
                                  ".prj (azimuthal equidistant on WGS84 centred at 50.0875, "
                                  "14.4213 deg = map point (1000, -500) m"));
  const AsciiGrid grid = ReadAsciiGrid(prefix + ".asc");
  EXPECT_EQ(grid.header.at("ncols"), 15);
  EXPECT_EQ(grid.header.at("nrows"), 10);
  EXPECT_EQ(grid.header.at("xllcorner"), 1000.0);
  EXPECT_EQ(grid.header.at("yllcorner"), -500.0);
  EXPECT_EQ(grid.header.at("cellsize"), 20.0);
  EXPECT_EQ(grid.header.at("NODATA_value"), -9999.0);

  // Values against the library, at the centre of each cell as the header
  // places it.
  auto map = LoadMapBundle(*dir_ + "/geo");
  ASSERT_TRUE(map.ok()) << map.status();
  auto model = RiskModel::Create(*map, ModelParams{});
  ASSERT_TRUE(model.ok());
  const double theta = 30.0 * kPi / 180.0;
  // On this 300 x 200 m map the impact window at 30 m reaches past the map
  // (NODATA) everywhere but in the middle (spec version 2).
  int positive = 0;
  int nodata = 0;
  for (auto [c, r] : {std::pair{0, 0}, {2, 9}, {7, 4}, {8, 5}, {6, 5}, {11, 1}, {14, 9}, {14, 0}}) {
    const double x = grid.header.at("xllcorner") + (c + 0.5) * grid.header.at("cellsize");
    const double y = grid.header.at("yllcorner") + (r + 0.5) * grid.header.at("cellsize");
    int i = 0;
    int j = 0;
    ASSERT_TRUE((*map)->CellOf(x, y, &i, &j));
    const ConfigurationRisk cr =
        (*model)->Evaluate(Pose{x, y, (*map)->terrain(i, j) + 30.0, theta});
    if (!cr.defined) {
      EXPECT_EQ(grid.rows[r][c], -9999.0) << c << ", " << r;
      ++nodata;
      continue;
    }
    EXPECT_NEAR(grid.rows[r][c], cr.risk, 1e-8 * cr.risk) << c << ", " << r;
    positive += cr.risk > 0.0;
  }
  EXPECT_GE(positive, 2);
  EXPECT_GE(nodata, 4);

  const std::string wkt = ReadFile(prefix + ".prj");
  EXPECT_THAT(wkt, HasSubstr("PROJCS[\"riskplan_geo-test_local_AEQD\",GEOGCS[\"GCS_WGS_1984\","
                             "DATUM[\"D_WGS_1984\",SPHEROID[\"WGS_1984\",6378137.0,"
                             "298.257223563]]"));
  EXPECT_THAT(wkt, HasSubstr("PROJECTION[\"Azimuthal_Equidistant\"]"));
  EXPECT_EQ(WktParameter(wkt, "False_Easting"), 1000.0);
  EXPECT_EQ(WktParameter(wkt, "False_Northing"), -500.0);
  EXPECT_EQ(WktParameter(wkt, "Latitude_Of_Origin"), kLatDeg);
  EXPECT_EQ(WktParameter(wkt, "Central_Meridian"), kLonDeg);
  EXPECT_THAT(wkt, HasSubstr("UNIT[\"Meter\",1.0]]"));

  std::ifstream png(prefix + ".png", std::ios::binary);
  char signature[8] = {};
  png.read(signature, 8);
  EXPECT_EQ(std::string(signature + 1, 3), "PNG");
}

TEST_F(RiskplanToolTest, RiskLayerWithoutGeoReferenceWritesNoProjection) {
  const std::string prefix = *dir_ + "/layer";
  std::ofstream(prefix + ".prj") << "left by an earlier run";
  const Output out =
      RunTool("risk-layer --map=" + *dir_ + "/city --out=" + prefix + " --agl_m=90 --threads=2");
  ASSERT_EQ(out.exit_code, 0) << out.text;
  EXPECT_THAT(out.text, HasSubstr("100 x 100 cells of 10 m at 90 m AGL"));
  EXPECT_THAT(out.text, HasSubstr("no .prj: the map has no geo-reference"));
  EXPECT_THAT(out.text, HasSubstr("removed a stale " + prefix + ".prj"));
  EXPECT_FALSE(std::filesystem::exists(prefix + ".prj"));
  const AsciiGrid grid = ReadAsciiGrid(prefix + ".asc");
  EXPECT_EQ(grid.header.at("ncols"), 100);
  EXPECT_EQ(grid.header.at("xllcorner"), 0.0);
  EXPECT_EQ(grid.header.at("cellsize"), 10.0);
  int width = 0;
  int height = 0;
  EXPECT_EQ(ReadPngRgb(prefix + ".png", &width, &height).size(), 100u * 100u * 3u);
  EXPECT_EQ(width, 100);
  EXPECT_EQ(height, 100);
}

TEST_F(RiskplanToolTest, RiskLayerMarksUndefinedRiskAsNodataAndGrey) {
  const std::string prefix = *dir_ + "/nodata";
  const Output out = RunTool("risk-layer --map=" + *dir_ + "/geo --out=" + prefix +
                             " --agl_m=1e-11 --heading_deg=max");
  ASSERT_EQ(out.exit_code, 0) << out.text;
  const AsciiGrid grid = ReadAsciiGrid(prefix + ".asc");
  ASSERT_EQ(grid.rows.size(), 20u);
  int width = 0;
  int height = 0;
  const std::vector<png_byte> rgb = ReadPngRgb(prefix + ".png", &width, &height);
  ASSERT_EQ(width, 30);
  ASSERT_EQ(height, 20);
  // The band along the edges where the impact window reaches past the map
  // (spec version 2) is NODATA too.
  auto map = LoadMapBundle(*dir_ + "/geo");
  ASSERT_TRUE(map.ok()) << map.status();
  auto model = RiskModel::Create(*map, ModelParams{});
  ASSERT_TRUE(model.ok());
  const ImpactReach reach = (*model)->Reach(1e-11);
  int zero = 0;
  int band = 0;
  for (int r = 0; r < 20; ++r) {
    for (int c = 0; c < 30; ++c) {
      const png_byte* px = &rgb[((19 - r) * 30 + c) * 3];  // north row first
      const bool grey = px[0] == 128 && px[1] == 128 && px[2] == 128;
      const double dx = (c + 0.5) * 10.0;
      const double dy = (r + 0.5) * 10.0;
      const bool clear = dx >= reach.west_m && 300.0 - dx > reach.east_m && dy >= reach.south_m &&
                         200.0 - dy > reach.north_m;
      if (c < 5 || !clear) {
        band += c >= 5 ? 1 : 0;
        EXPECT_EQ(grid.rows[r][c], -9999.0) << c << ", " << r;
        EXPECT_TRUE(grey) << c << ", " << r;
      } else {
        EXPECT_GE(grid.rows[r][c], 0.0) << c << ", " << r;
        EXPECT_FALSE(grey) << c << ", " << r;
        if (grid.rows[r][c] == 0.0) {
          ++zero;  // M = 0 keeps its own colour
          EXPECT_TRUE(px[0] == 10 && px[1] == 20 && px[2] == 60) << c << ", " << r;
        }
      }
    }
  }
  EXPECT_GT(zero, 0);
  EXPECT_GT(band, 50);
}

TEST_F(RiskplanToolTest, RiskLayerRefusesBadOptionsAndABadGeoReference) {
  const std::string prefix = *dir_ + "/refused";
  Output out =
      RunTool("risk-layer --map=" + *dir_ + "/city --out=" + prefix + " --heading_deg=north");
  EXPECT_EQ(out.exit_code, 2);
  EXPECT_THAT(out.text, HasSubstr("'north' is neither a number of degrees nor 'max'"));
  out = RunTool("risk-layer --map=" + *dir_ + "/city --out=" + prefix + " --stride=101");
  EXPECT_EQ(out.exit_code, 2);
  EXPECT_THAT(out.text, HasSubstr("stride 101 is larger than the map of 100 x 100 cells"));
  out = RunTool("risk-layer --map=" + *dir_ + "/bad-geo --out=" + prefix);
  EXPECT_EQ(out.exit_code, 2);
  EXPECT_THAT(out.text, HasSubstr("latitude in [-90, 90]"));
  EXPECT_FALSE(std::filesystem::exists(prefix + ".asc"));
}

}  // namespace
}  // namespace riskplan
