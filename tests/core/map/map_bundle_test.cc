#include "core/map/map_bundle.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/core/map/test_dir_cleanup.h"

namespace riskplan {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using ::testing::HasSubstr;

// A fresh, empty directory per test.
std::string TestDir(const std::string& leaf = "bundle") {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const fs::path dir = fs::path(::testing::TempDir()) /
                       ::riskplan::testing::ProcessRoot("riskplan_map_bundle_test") /
                       (std::string(info->name()) + "_" + leaf);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string();
}

std::shared_ptr<const RiskMap> SmallMap(const std::string& name = "small-map") {
  MapHeader header;
  header.name = name;
  header.x0 = -1234.5678901234567;
  header.y0 = 0.1 + 0.2;  // not exactly representable in decimal: tests the JSON round trip
  header.res = 2.5;
  header.nx = 10;
  header.ny = 7;
  header.geo = GeoReference{50.0755381, 14.4378005, "local ENU tangent plane"};
  header.provenance = "unit test \"quoted\", ünïcödé";
  MapLayers layers;
  const size_t n = 70;
  for (size_t k = 0; k < n; ++k) {
    layers.density.push_back(static_cast<float>(k) * 1e-4f / 3.0f);
    layers.shelter.push_back(static_cast<float>(k % 11) * (10.0f / 10.0f));
    layers.terrain.push_back(-5.0f + static_cast<float>(k) * 3.3f);
    layers.nofly.push_back(k % 9 == 4 ? 1 : 0);
  }
  layers.density[1] = std::numeric_limits<float>::denorm_min();
  layers.density[2] = -0.0f;  // >= 0 holds; the sign bit must survive the round trip
  layers.landing_sites = {{"park-1", 0, 0}, {"", 9, 6}, {"field-2", 3, 5}};
  auto map = RiskMap::Create(header, layers, 10.0, 10.0);
  EXPECT_TRUE(map.ok()) << map.status();
  return *map;
}

std::string WrittenBundle(const std::string& leaf = "bundle") {
  const std::string dir = TestDir(leaf);
  EXPECT_TRUE(WriteMapBundle(*SmallMap(), dir).ok());
  return dir;
}

std::string ReadFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void WriteFile(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << bytes;
}

void EditManifest(const std::string& dir, const std::function<void(Json&)>& edit) {
  Json manifest = Json::parse(ReadFile(fs::path(dir) / "manifest.json"));
  edit(manifest);
  WriteFile(fs::path(dir) / "manifest.json", manifest.dump(2));
}

// Overwrites one float32 cell of a layer file and drops that layer's checksum
// (checksums are optional), so that the domain check is what refuses it.
void PokeFloat(const std::string& dir, const std::string& layer, int index, float value) {
  const fs::path path = fs::path(dir) / (layer + ".f32");
  std::string bytes = ReadFile(path);
  std::memcpy(bytes.data() + 4 * index, &value, 4);  // the test host is little-endian
  WriteFile(path, bytes);
  EditManifest(dir, [&](Json& m) { m["layers"][layer].erase("sha256"); });
}

std::string LoadError(const std::string& dir, absl::StatusCode code) {
  auto map = LoadMapBundle(dir);
  EXPECT_FALSE(map.ok());
  if (map.ok()) return "";
  EXPECT_EQ(map.status().code(), code) << map.status();
  return std::string(map.status().message());
}

std::string LoadError(const std::string& dir) {
  return LoadError(dir, absl::StatusCode::kInvalidArgument);
}

// Every test's folder is under TempDir()/riskplan_map_bundle_test, removed when
// the program ends.
const ::testing::Environment* const kCleanup =
    ::riskplan::testing::RemoveAtExit("riskplan_map_bundle_test");

TEST(MapBundleTest, ARunLeavesNoFolderBehind) {
  EXPECT_THAT(::riskplan::testing::LeftBehind("MapBundleTest.RoundTripIsBitExact"),
              ::testing::IsEmpty());
}

TEST(MapBundleTest, RoundTripIsBitExact) {
  auto original = SmallMap();
  const std::string dir = TestDir();
  ASSERT_TRUE(WriteMapBundle(*original, dir).ok());
  auto loaded = LoadMapBundle(dir);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  const RiskMap& a = *original;
  const RiskMap& b = **loaded;
  EXPECT_EQ(a.name(), b.name());
  EXPECT_EQ(std::memcmp(&a.header().x0, &b.header().x0, sizeof(double)), 0);
  EXPECT_EQ(std::memcmp(&a.header().y0, &b.header().y0, sizeof(double)), 0);
  EXPECT_EQ(a.res(), b.res());
  EXPECT_EQ(a.nx(), b.nx());
  EXPECT_EQ(a.ny(), b.ny());
  EXPECT_EQ(a.header().provenance, b.header().provenance);
  ASSERT_TRUE(b.header().geo.has_value());
  EXPECT_EQ(a.header().geo->origin_lat_deg, b.header().geo->origin_lat_deg);
  EXPECT_EQ(a.header().geo->origin_lon_deg, b.header().geo->origin_lon_deg);
  EXPECT_EQ(a.header().geo->crs, b.header().geo->crs);
  const size_t n = 70;
  EXPECT_EQ(std::memcmp(a.layers().density.data(), b.layers().density.data(), 4 * n), 0);
  EXPECT_EQ(std::memcmp(a.layers().shelter.data(), b.layers().shelter.data(), 4 * n), 0);
  EXPECT_EQ(std::memcmp(a.layers().terrain.data(), b.layers().terrain.data(), 4 * n), 0);
  EXPECT_EQ(a.layers().nofly, b.layers().nofly);
  ASSERT_EQ(a.landing_sites().size(), b.landing_sites().size());
  for (size_t k = 0; k < a.landing_sites().size(); ++k) {
    EXPECT_EQ(a.landing_sites()[k].name, b.landing_sites()[k].name);
    EXPECT_EQ(a.landing_sites()[k].i, b.landing_sites()[k].i);
    EXPECT_EQ(a.landing_sites()[k].j, b.landing_sites()[k].j);
  }
  EXPECT_EQ(a.glide_altitude(), b.glide_altitude());

  // Writing the loaded map again gives the same files, byte for byte, and
  // replaces an existing bundle without leaving temporary files behind.
  const std::string again = TestDir("again");
  ASSERT_TRUE(WriteMapBundle(b, again).ok());
  ASSERT_TRUE(WriteMapBundle(b, again).ok());
  int files = 0;
  for (const auto& entry : fs::directory_iterator(again)) {
    ++files;
    EXPECT_EQ(ReadFile(entry.path()), ReadFile(fs::path(dir) / entry.path().filename()))
        << entry.path();
  }
  EXPECT_EQ(files, 5);
}

TEST(MapBundleTest, ManifestDescribesTheLayers) {
  const std::string dir = WrittenBundle();
  const Json m = Json::parse(ReadFile(fs::path(dir) / "manifest.json"));
  EXPECT_EQ(m["format"], "riskplan-map-bundle");
  EXPECT_EQ(m["version"], 1);
  EXPECT_EQ(m["layers"]["density"]["file"], "density.f32");
  EXPECT_EQ(m["layers"]["nofly"]["dtype"], "uint8");
  EXPECT_EQ(m["layers"]["terrain"]["byte_order"], "little");
  EXPECT_EQ(m["layers"]["shelter"]["row_order"], "south_to_north");
  EXPECT_EQ(m["layers"]["nofly"]["sha256"].get<std::string>().size(), 64u);
  EXPECT_EQ(fs::file_size(fs::path(dir) / "density.f32"), 280u);
  EXPECT_EQ(fs::file_size(fs::path(dir) / "nofly.u8"), 70u);
}

TEST(MapBundleTest, MinimalManifestWithoutOptionalFieldsLoads) {
  const std::string dir = WrittenBundle();
  EditManifest(dir, [](Json& m) {
    m.erase("geo");
    m.erase("provenance");
    m.erase("landing_sites");
    for (auto& [name, layer] : m["layers"].items()) layer.erase("sha256");
  });
  auto map = LoadMapBundle(dir);
  ASSERT_TRUE(map.ok()) << map.status();
  EXPECT_FALSE((*map)->header().geo.has_value());
  EXPECT_TRUE((*map)->landing_sites().empty());
}

TEST(MapBundleTest, RefusesMissingManifest) {
  const std::string dir = TestDir();
  EXPECT_THAT(LoadError(dir, absl::StatusCode::kNotFound), HasSubstr("manifest.json not found"));
  EXPECT_THAT(LoadError(dir + "/does-not-exist", absl::StatusCode::kNotFound),
              HasSubstr("manifest.json not found"));
}

TEST(MapBundleTest, RefusesMalformedJsonWithItsPosition) {
  const std::string dir = WrittenBundle();
  WriteFile(fs::path(dir) / "manifest.json",
            "{\n  \"format\": \"riskplan-map-bundle\",\n  nx: 3\n}");
  const std::string error = LoadError(dir);
  EXPECT_THAT(error, HasSubstr("manifest.json is not valid JSON"));
  EXPECT_THAT(error, HasSubstr("parse error at line 3, column "));
  WriteFile(fs::path(dir) / "manifest.json", "[1, 2]");
  EXPECT_THAT(LoadError(dir), HasSubstr("top level must be an object, got array"));
}

TEST(MapBundleTest, RefusesMissingFields) {
  for (const char* field : {"format", "version", "name", "x0", "y0", "res", "nx", "ny", "layers"}) {
    const std::string dir = WrittenBundle();
    EditManifest(dir, [&](Json& m) { m.erase(field); });
    EXPECT_THAT(LoadError(dir), HasSubstr(std::string("missing field '") + field + "'"));
  }
  const std::string dir = WrittenBundle();
  EditManifest(dir, [](Json& m) { m["layers"]["nofly"].erase("dtype"); });
  EXPECT_THAT(LoadError(dir), HasSubstr("missing field 'layers.nofly.dtype'"));
  EditManifest(dir, [](Json& m) { m["layers"].erase("terrain"); });
  EXPECT_THAT(LoadError(dir), HasSubstr("missing field 'layers.terrain'"));
  EditManifest(dir, [](Json& m) { m["landing_sites"] = Json::array({{{"name", "x"}, {"i", 1}}}); });
  EXPECT_THAT(LoadError(dir), HasSubstr("missing field 'landing_sites[0].j'"));
}

TEST(MapBundleTest, RefusesIllTypedFields) {
  const std::string dir = WrittenBundle();
  EditManifest(dir, [](Json& m) { m["nx"] = "10"; });
  EXPECT_THAT(LoadError(dir), HasSubstr("field 'nx' must be an integer, got string"));
  EditManifest(dir, [](Json& m) { m["nx"] = 10.0; });
  EXPECT_THAT(LoadError(dir), HasSubstr("field 'nx' must be an integer, got number"));
  EditManifest(dir, [](Json& m) {
    m["nx"] = 10;
    m["res"] = "2.5";
  });
  EXPECT_THAT(LoadError(dir), HasSubstr("field 'res' must be a number, got string"));
  EditManifest(dir, [](Json& m) {
    m["res"] = 2.5;
    m["ny"] = 1ll << 40;
  });
  EXPECT_THAT(LoadError(dir), HasSubstr("field 'ny' has value 1099511627776"));
  EditManifest(dir, [](Json& m) {
    m["ny"] = 7;
    m["layers"]["density"] = "density.f32";
  });
  EXPECT_THAT(LoadError(dir), HasSubstr("field 'layers.density' must be an object, got string"));
}

TEST(MapBundleTest, RefusesUnknownFormatOrVersion) {
  const std::string dir = WrittenBundle();
  EditManifest(dir, [](Json& m) { m["version"] = 2; });
  EXPECT_THAT(LoadError(dir), HasSubstr("unsupported version 2; this build reads version 1"));
  EditManifest(dir, [](Json& m) {
    m["version"] = 1;
    m["format"] = "geotiff";
  });
  EXPECT_THAT(LoadError(dir),
              HasSubstr("field 'format' is 'geotiff'; expected 'riskplan-map-bundle'"));
}

TEST(MapBundleTest, RefusesWrongLayerDescriptions) {
  const std::string dir = WrittenBundle();
  EditManifest(dir, [](Json& m) { m["layers"]["nofly"]["dtype"] = "float32"; });
  EXPECT_THAT(LoadError(dir),
              HasSubstr("field 'layers.nofly.dtype' is 'float32'; expected 'uint8'"));
  EditManifest(dir, [](Json& m) {
    m["layers"]["nofly"]["dtype"] = "uint8";
    m["layers"]["terrain"]["byte_order"] = "big";
  });
  EXPECT_THAT(LoadError(dir), HasSubstr("'layers.terrain.byte_order' is 'big'; expected 'little'"));
  EditManifest(dir, [](Json& m) {
    m["layers"]["terrain"]["byte_order"] = "little";
    m["layers"]["shelter"]["row_order"] = "north_to_south";
  });
  EXPECT_THAT(LoadError(dir), HasSubstr("expected 'south_to_north'"));
  EditManifest(dir, [](Json& m) {
    m["layers"]["shelter"]["row_order"] = "south_to_north";
    m["layers"]["density"]["file"] = "../density.f32";
  });
  EXPECT_THAT(LoadError(dir), HasSubstr("expected a plain file name"));
  EditManifest(dir, [](Json& m) {
    m["layers"]["density"]["file"] = "density.f32";
    m["layers"]["density"]["sha256"] = "abc";
  });
  EXPECT_THAT(LoadError(dir), HasSubstr("'layers.density.sha256' must be 64 hexadecimal digits"));
}

TEST(MapBundleTest, RefusesMissingLayerFile) {
  const std::string dir = WrittenBundle();
  fs::remove(fs::path(dir) / "terrain.f32");
  EXPECT_THAT(LoadError(dir, absl::StatusCode::kNotFound),
              HasSubstr("layer 'terrain': file 'terrain.f32' not found"));
}

TEST(MapBundleTest, RefusesTruncatedLayerFile) {
  const std::string dir = WrittenBundle();
  fs::resize_file(fs::path(dir) / "density.f32", 276);
  EXPECT_THAT(LoadError(dir), HasSubstr("layer 'density': file 'density.f32' has 276 bytes; "
                                        "expected 280 (nx*ny = 70 cells of float32)"));
  const std::string other = WrittenBundle("other");
  fs::resize_file(fs::path(other) / "nofly.u8", 71);
  EXPECT_THAT(LoadError(other),
              HasSubstr("layer 'nofly': file 'nofly.u8' has 71 bytes; expected 70"));
}

TEST(MapBundleTest, RefusesChecksumMismatch) {
  const std::string dir = WrittenBundle();
  const fs::path path = fs::path(dir) / "terrain.f32";
  std::string bytes = ReadFile(path);
  bytes[8] ^= 1;  // lowest mantissa bit of cell 2: still a valid terrain value
  WriteFile(path, bytes);
  const std::string error = LoadError(dir);
  EXPECT_THAT(error, HasSubstr("layer 'terrain': file 'terrain.f32' has SHA-256 "));
  EXPECT_THAT(error, HasSubstr("; manifest.json says "));
  // Without a checksum the same file loads.
  EditManifest(dir, [](Json& m) { m["layers"]["terrain"].erase("sha256"); });
  EXPECT_TRUE(LoadMapBundle(dir).ok());
}

TEST(MapBundleTest, RefusesOutOfDomainValues) {
  std::string dir = WrittenBundle("nan");
  PokeFloat(dir, "density", 2 * 10 + 3, std::numeric_limits<float>::quiet_NaN());
  EXPECT_THAT(LoadError(dir),
              HasSubstr("layer 'density': cell (3, 2) has value nan; density must be >= 0"));
  dir = WrittenBundle("negative");
  PokeFloat(dir, "density", 5, -0.5f);
  EXPECT_THAT(LoadError(dir), HasSubstr("layer 'density': cell (5, 0) has value -0.5"));
  dir = WrittenBundle("shelter");
  PokeFloat(dir, "shelter", 6 * 10 + 9, 11.0f);
  EXPECT_THAT(LoadError(dir),
              HasSubstr("layer 'shelter': cell (9, 6) has value 11; shelter must be in [0, 10]"));
  dir = WrittenBundle("nofly");
  std::string nofly = ReadFile(fs::path(dir) / "nofly.u8");
  nofly[12] = 2;
  WriteFile(fs::path(dir) / "nofly.u8", nofly);
  EditManifest(dir, [](Json& m) { m["layers"]["nofly"].erase("sha256"); });
  EXPECT_THAT(LoadError(dir),
              HasSubstr("layer 'nofly': cell (2, 1) has value 2; nofly must be 0 or 1"));
  dir = WrittenBundle("site");
  EditManifest(dir, [](Json& m) { m["landing_sites"][1]["i"] = 10; });
  EXPECT_THAT(LoadError(dir), HasSubstr("site '' at cell (10, 6) is outside the map of 10 x 7"));
  dir = WrittenBundle("header");
  EditManifest(dir, [](Json& m) { m["res"] = -1; });
  EXPECT_THAT(LoadError(dir), HasSubstr("res has value -1; res must be > 0"));
  EditManifest(dir, [](Json& m) {
    m["res"] = 2.5;
    m["name"] = "Bad Name";
  });
  EXPECT_THAT(LoadError(dir), HasSubstr("name 'Bad Name' is invalid"));
}

TEST(MapBundleTest, ErrorsNameTheBundle) {
  const std::string dir = WrittenBundle();
  fs::remove(fs::path(dir) / "nofly.u8");
  EXPECT_THAT(LoadError(dir, absl::StatusCode::kNotFound), HasSubstr("map bundle '" + dir + "'"));
}

TEST(MapBundleTest, GlideUsesTheGivenParams) {
  const std::string dir = WrittenBundle();
  ModelParams params;
  params.glide_ratio = 5.0;
  params.glide_clearance_m = 20.0;
  auto map = LoadMapBundle(dir, params);
  ASSERT_TRUE(map.ok()) << map.status();
  EXPECT_EQ((*map)->glide_ratio(), 5.0);
  EXPECT_EQ((*map)->glide_clearance_m(), 20.0);
  EXPECT_DOUBLE_EQ((*map)->glide_altitude()[0], (*map)->terrain(0, 0) + 20.0);
}

TEST(MapBundleTest, LoadMapDirectoryLoadsBundlesSortedAndRefusesDuplicates) {
  const fs::path root = TestDir("maps");
  ASSERT_TRUE(WriteMapBundle(*SmallMap("zeta"), (root / "a").string()).ok());
  ASSERT_TRUE(WriteMapBundle(*SmallMap("alpha"), (root / "b").string()).ok());
  fs::create_directories(root / "not-a-bundle");
  WriteFile(root / "README", "ignored");
  auto maps = LoadMapDirectory(root.string());
  ASSERT_TRUE(maps.ok()) << maps.status();
  ASSERT_EQ(maps->size(), 2u);
  EXPECT_EQ((*maps)[0]->name(), "zeta");  // sorted by directory name, not map name
  EXPECT_EQ((*maps)[1]->name(), "alpha");

  ASSERT_TRUE(WriteMapBundle(*SmallMap("zeta"), (root / "c").string()).ok());
  maps = LoadMapDirectory(root.string());
  ASSERT_FALSE(maps.ok());
  EXPECT_THAT(maps.status().message(), HasSubstr("both hold map 'zeta'"));

  fs::remove_all(root / "c");
  fs::remove(root / "b" / "shelter.f32");
  maps = LoadMapDirectory(root.string());
  ASSERT_FALSE(maps.ok());
  EXPECT_EQ(maps.status().code(), absl::StatusCode::kNotFound);

  auto empty = LoadMapDirectory(TestDir("empty"));
  ASSERT_TRUE(empty.ok());
  EXPECT_TRUE(empty->empty());
  EXPECT_EQ(LoadMapDirectory((root / "missing").string()).status().code(),
            absl::StatusCode::kNotFound);
}

}  // namespace
}  // namespace riskplan
