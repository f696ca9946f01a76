// Fuzz target: the geo importer's inputs (geo/map_importer.h, ImportMap), a
// raster or vector file's bytes read by the importer's own code through
// GDAL's in-memory file system (/vsimem/), imported onto a tiny area
// (200 m x 160 m at 20 m cells near Luxembourg city) as riskplan-tool
// import does.
//
// Input: one byte choosing what the file is given as, then the files: the
// first line is the input's name (for a vector input it may carry the
// QGIS-style options "|layername=NAME|where=SQL" of VectorSpec), then its
// bytes; any further file is introduced by a line "%%file NAME" (as in the
// map_bundle target: the separator is "\n%%file ", the name runs to the next
// newline). Files are written under /vsimem/fuzz/, so that a .prj or .shx
// beside the input is found as GDAL would find it on disk.
//
//   choice & 7:  0 terrain (DEM raster)       1 population raster
//                2 population polygons, count field "pop"
//                3 land-cover raster          4 building footprints
//                5 no-fly zones (buffer 15 m) 6, 7 landing sites, name field "name"
//   choice & 8:  fill rules on (terrain nearest, density 0, shelter 2.5)
//   choice & 16: population rasters per km^2; land cover as CORINE classes
//   choice & 32: landing sites also derived from open land cover (400 m^2)
// Every input but the terrain is imported over a fixed, valid DEM.
//
// Only the drivers an importer's user would hand it in a small file are
// registered (GTiff, AAIGrid, XYZ, SRTMHGT, GeoJSON, GeoJSONSeq, ESRI
// Shapefile, CSV, KML, OSM, with MEM and VRT, which the importer itself
// uses), so that the time goes to the importer's paths, not to every format
// GDAL knows. GDAL and PROJ are Debian's, not instrumented: their code runs,
// and ASan sees their heap through its allocator, but the fuzzer is guided
// only by the coverage of riskplan's code.
//
// Properties: a refusal is InvalidArgument or NotFound with a message
// (map_importer.h); no exception escapes; an import that succeeds has every
// layer of nx * ny cells, passes RiskMap::Create (what riskplan-tool import
// checks before writing) and has no landing site in a no-fly cell.
#include <cpl_conv.h>
#include <cpl_vsi.h>
#include <gdal_priv.h>

#include <cmath>
#include <cstdint>
#include <exception>
#include <memory>
#include <set>
#include <string>
#include <string_view>
#include <utility>

#include "absl/status/status.h"
#include "core/map/risk_map.h"
#include "fuzz/fuzz_support.h"
#include "geo/gdal_util.h"
#include "geo/map_importer.h"

namespace riskplan::fuzz {
namespace {

constexpr std::string_view kSeparator = "\n%%file ";
constexpr const char* kFuzzDir = "/vsimem/fuzz";
constexpr const char* kFixedDem = "/vsimem/fixed/dem.tif";

// The drivers left registered (GDAL's short names).
const std::set<std::string>& KeptDrivers() {
  static const std::set<std::string> kept = {
      "GTiff", "AAIGrid",    "XYZ", "SRTMHGT", "GeoJSON", "GeoJSONSeq", "ESRI Shapefile",
      "CSV",   "KML",        "OSM", "MEM",     "VRT"};
  return kept;
}

void WriteVsiFile(const std::string& path, std::string_view bytes) {
  VSILFILE* f = VSIFOpenL(path.c_str(), "wb");
  if (f == nullptr) Fail("cannot create " + path);
  if (!bytes.empty() && VSIFWriteL(bytes.data(), 1, bytes.size(), f) != bytes.size()) {
    Fail("cannot write " + path);
  }
  VSIFCloseL(f);
}

// GDAL set up once: the importer's own registration, then every driver
// outside KeptDrivers() removed; no network; a small block cache; the fixed
// DEM (300-340 m, a gentle slope) in EPSG:4326 over the area and beyond.
void SetUpGdal() {
  geo::EnsureGdalRegistered();
  // GDAL's messages on threads without the importer's capture (the warp's
  // worker threads) would flood the fuzzer's output.
  CPLSetErrorHandler(CPLQuietErrorHandler);
  CPLSetConfigOption("GDAL_CACHEMAX", "16");
  CPLSetConfigOption("GDAL_DISABLE_READDIR_ON_OPEN", "EMPTY_DIR");
  CPLSetConfigOption("GDAL_VRT_ENABLE_PYTHON", "NO");
  CPLSetConfigOption("GDAL_HTTP_TIMEOUT", "1");
  CPLSetConfigOption("GDAL_HTTP_MAX_RETRY", "0");
  GDALDriverManager* drivers = GetGDALDriverManager();
  for (int k = drivers->GetDriverCount() - 1; k >= 0; --k) {
    GDALDriver* driver = drivers->GetDriver(k);
    if (KeptDrivers().count(driver->GetDescription()) == 0) {
      drivers->DeregisterDriver(driver);
      GDALDestroyDriver(driver);
    }
  }
  GDALDriver* gtiff = drivers->GetDriverByName("GTiff");
  if (gtiff == nullptr) Fail("no GTiff driver");
  constexpr int kWidth = 40, kHeight = 30;
  GDALDatasetUniquePtr dem(gtiff->Create(kFixedDem, kWidth, kHeight, 1, GDT_Float32, nullptr));
  if (dem == nullptr) Fail("cannot create the fixed DEM");
  double gt[6] = {6.120, 0.0005, 0.0, 49.620, 0.0, -0.0005};
  dem->SetGeoTransform(gt);
  geo::SpatialReferencePtr wgs84 = geo::Wgs84Lonlat();
  dem->SetSpatialRef(wgs84.get());
  std::vector<float> heights(kWidth * kHeight);
  for (int j = 0; j < kHeight; ++j) {
    for (int i = 0; i < kWidth; ++i) heights[j * kWidth + i] = 300.0f + i + j * 0.5f;
  }
  if (dem->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, kWidth, kHeight, heights.data(), kWidth,
                                      kHeight, GDT_Float32, 0, 0, nullptr) != CE_None) {
    Fail("cannot write the fixed DEM");
  }
}

bool PlainName(std::string_view name) {
  return !name.empty() && name.size() <= 100 && name != "." && name != ".." &&
         name.find_first_of(std::string_view("/\\\0", 3)) == std::string_view::npos;
}

// Writes the input's files under kFuzzDir; returns the first one's name line
// (the input as the importer is given it), or "" if it has no usable name.
std::string WriteFiles(std::string_view input) {
  const size_t name_end = input.find('\n');
  if (name_end == std::string_view::npos) return "";
  const std::string_view spec = input.substr(0, name_end);
  const std::string_view name = spec.substr(0, spec.find('|'));
  if (!PlainName(name)) return "";
  size_t end = input.find(kSeparator, name_end + 1);
  WriteVsiFile(std::string(kFuzzDir) + "/" + std::string(name),
               input.substr(name_end + 1, end == std::string_view::npos ? end : end - name_end - 1));
  while (end != std::string_view::npos) {
    const size_t other_start = end + kSeparator.size();
    const size_t other_end = input.find('\n', other_start);
    if (other_end == std::string_view::npos) break;
    const std::string_view other = input.substr(other_start, other_end - other_start);
    end = input.find(kSeparator, other_end + 1);
    const std::string_view bytes = input.substr(
        other_end + 1, end == std::string_view::npos ? end : end - other_end - 1);
    if (PlainName(other)) WriteVsiFile(std::string(kFuzzDir) + "/" + std::string(other), bytes);
  }
  return std::string(kFuzzDir) + "/" + std::string(spec);
}

geo::ImportOptions Options(uint8_t choice, const std::string& input) {
  geo::ImportOptions o;
  o.name = "fuzz-town";
  o.area.center = geo::LatLon{49.611, 6.130};
  o.area.width_m = 200.0;
  o.area.height_m = 160.0;
  o.area.res_m = 20.0;
  o.threads = 1;
  o.command_line = "fuzz";
  o.terrain = kFixedDem;
  if (choice & 8) {
    o.terrain_fill.kind = geo::FillRule::Kind::kNearest;
    o.density_fill = {geo::FillRule::Kind::kValue, 0.0};
    o.shelter_fill = {geo::FillRule::Kind::kValue, 2.5};
  }
  switch (choice & 7) {
    case 0:
      o.terrain = input;
      break;
    case 1:
      o.population = input;
      if (choice & 16) o.population_unit = geo::PopulationUnit::kPerKm2;
      break;
    case 2:
      o.population = input;
      o.population_field = "pop";
      break;
    case 3:
      o.landcover = input;
      if (choice & 16) o.landcover_classes = "corine";
      break;
    case 4:
      o.buildings = input;
      break;
    case 5:
      o.nofly = {input};
      o.nofly_buffer_m = 15.0;
      break;
    default:
      o.landing = {input};
      o.landing_name_field = "name";
      break;
  }
  if (choice & 32) o.landing_min_area_m2 = 400.0;
  return o;
}

void CheckImported(geo::ImportedMap& imported) {
  const size_t cells = static_cast<size_t>(imported.header.nx) * imported.header.ny;
  const MapLayers& l = imported.layers;
  if (l.terrain.size() != cells || l.density.size() != cells || l.shelter.size() != cells ||
      l.nofly.size() != cells) {
    Fail("an imported layer of the wrong size");
  }
  if (!std::isfinite(imported.stats.people_total)) Fail("a non-finite number of people");
  for (const LandingSite& site : l.landing_sites) {
    if (site.i < 0 || site.j < 0 || site.i >= imported.header.nx || site.j >= imported.header.ny) {
      Fail("a landing site outside the map");
    }
    if (l.nofly[static_cast<size_t>(site.j) * imported.header.nx + site.i] != 0) {
      Fail("a landing site in a no-fly cell");
    }
  }
  absl::StatusOr<std::shared_ptr<const RiskMap>> map =
      RiskMap::Create(std::move(imported.header), std::move(imported.layers));
  if (!map.ok()) Fail("RiskMap::Create refuses an imported map: " + map.status().ToString());
}

void Run(const uint8_t* data, size_t size) {
  if (size == 0) return;
  const std::string input =
      WriteFiles(std::string_view(reinterpret_cast<const char*>(data) + 1, size - 1));
  if (input.empty()) return;
  absl::StatusOr<geo::ImportedMap> imported = geo::ImportMap(Options(data[0], input));
  if (!imported.ok()) {
    const absl::Status& s = imported.status();
    if ((!absl::IsInvalidArgument(s) && !absl::IsNotFound(s)) || s.message().empty()) {
      Fail(s.ToString());
    }
    return;
  }
  CheckImported(*imported);
}

}  // namespace
}  // namespace riskplan::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const bool set_up = (riskplan::fuzz::SetUpGdal(), true);
  (void)set_up;
  try {
    riskplan::fuzz::Run(data, size);
  } catch (const std::exception& e) {
    riskplan::fuzz::Fail(std::string("an exception escaped: ") + e.what());
  }
  VSIRmdirRecursive(riskplan::fuzz::kFuzzDir);
  return 0;
}
