#include "tests/geo/geodata_fixtures.h"

#include <cpl_conv.h>
#include <gdal_priv.h>
#include <ogr_geometry.h>
#include <ogrsf_frmts.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/strip.h"
#include "geo/gdal_util.h"
#include "gtest/gtest.h"

namespace riskplan::geo::testing {
namespace fs = std::filesystem;

namespace {

// The process's own directory under the test temp dir, removed with
// everything in it when the process exits normally (a test that fails still
// exits normally; one that crashes leaves it, for a look at what it wrote).
// A forked child that exits does not remove its parent's directory.
const fs::path& ProcessDir() {
  struct Owned {
    pid_t owner = ::getpid();
    fs::path path = fs::path(::testing::TempDir()) / absl::StrCat("riskplan-geo-", owner);
    ~Owned() {
      if (::getpid() != owner) return;
      std::error_code ec;
      fs::remove_all(path, ec);
    }
  };
  static const Owned owned;
  return owned.path;
}

}  // namespace

std::string FreshDir(const std::string& name) {
  const fs::path dir = ProcessDir() / name;
  std::error_code ec;
  fs::remove_all(dir, ec);
  fs::create_directories(dir, ec);
  return dir.string();
}

absl::Status WriteRaster(const std::string& path, const RasterSpec& spec) {
  EnsureGdalRegistered();
  GdalErrorCapture errors;
  if (spec.values.size() != static_cast<size_t>(spec.width) * spec.height) {
    return absl::InvalidArgumentError("values do not fill the raster");
  }
  auto srs = SpatialReferenceFrom(spec.srs);
  if (!srs.ok()) return srs.status();
  GDALDriver* mem = GetGDALDriverManager()->GetDriverByName("MEM");
  GDALDatasetUniquePtr ds(mem->Create("", spec.width, spec.height, 1, spec.type, nullptr));
  if (ds == nullptr) return absl::InternalError(errors.Errors());
  double gt[6];
  std::copy(spec.geotransform, spec.geotransform + 6, gt);
  ds->SetGeoTransform(gt);
  ds->SetSpatialRef(srs->get());
  if (!spec.area_or_point.empty()) {
    ds->SetMetadataItem(GDALMD_AREA_OR_POINT, spec.area_or_point.c_str());
  }
  GDALRasterBand* band = ds->GetRasterBand(1);
  if (spec.has_nodata) band->SetNoDataValue(spec.nodata);
  std::vector<double> values = spec.values;
  if (band->RasterIO(GF_Write, 0, 0, spec.width, spec.height, values.data(), spec.width,
                     spec.height, GDT_Float64, 0, 0, nullptr) != CE_None) {
    return absl::InternalError(errors.Errors());
  }
  if (!spec.mask.empty()) {
    if (ds->CreateMaskBand(GMF_PER_DATASET) != CE_None) return absl::InternalError(errors.Errors());
    std::vector<uint8_t> mask = spec.mask;
    for (uint8_t& m : mask) m = m != 0 ? 255 : 0;
    if (band->GetMaskBand()->RasterIO(GF_Write, 0, 0, spec.width, spec.height, mask.data(),
                                      spec.width, spec.height, GDT_Byte, 0, 0,
                                      nullptr) != CE_None) {
      return absl::InternalError(errors.Errors());
    }
  }
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName(spec.driver.c_str());
  if (driver == nullptr) return absl::InternalError("no driver " + spec.driver);
  if (spec.raw_point_tiepoint) CPLSetThreadLocalConfigOption("GTIFF_POINT_GEO_IGNORE", "TRUE");
  GDALDatasetUniquePtr out(
      driver->CreateCopy(path.c_str(), ds.get(), /*strict=*/FALSE, nullptr, nullptr, nullptr));
  if (spec.raw_point_tiepoint) CPLSetThreadLocalConfigOption("GTIFF_POINT_GEO_IGNORE", nullptr);
  if (out == nullptr) return absl::InternalError(errors.Errors());
  return absl::OkStatus();
}

absl::Status WriteVector(const std::string& path, const std::string& driver_name,
                         const std::string& srs_text, const std::string& layer_name,
                         const std::vector<FeatureSpec>& features) {
  EnsureGdalRegistered();
  GdalErrorCapture errors;
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName(driver_name.c_str());
  if (driver == nullptr) return absl::InternalError("no driver " + driver_name);
  GDALDatasetUniquePtr ds(driver->Create(path.c_str(), 0, 0, 0, GDT_Unknown, nullptr));
  if (ds == nullptr) return absl::InternalError(errors.Errors());
  auto srs = SpatialReferenceFrom(srs_text);
  if (!srs.ok()) return srs.status();
  OGRLayer* layer = ds->CreateLayer(layer_name.c_str(), srs->get(), wkbUnknown, nullptr);
  if (layer == nullptr) return absl::InternalError(errors.Errors());
  std::set<std::string> numbers, texts;
  for (const FeatureSpec& f : features) {
    for (const auto& [k, v] : f.numbers) numbers.insert(k);
    for (const auto& [k, v] : f.texts) texts.insert(k);
  }
  for (const std::string& n : numbers) {
    OGRFieldDefn field(n.c_str(), OFTReal);
    layer->CreateField(&field);
  }
  for (const std::string& n : texts) {
    OGRFieldDefn field(n.c_str(), OFTString);
    layer->CreateField(&field);
  }
  for (const FeatureSpec& f : features) {
    OGRFeatureUniquePtr feature(OGRFeature::CreateFeature(layer->GetLayerDefn()));
    OGRGeometry* geometry = nullptr;
    if (OGRGeometryFactory::createFromWkt(f.wkt.c_str(), nullptr, &geometry) != OGRERR_NONE) {
      return absl::InvalidArgumentError("bad WKT " + f.wkt);
    }
    feature->SetGeometryDirectly(geometry);
    for (const auto& [k, v] : f.numbers) feature->SetField(k.c_str(), v);
    for (const auto& [k, v] : f.texts) feature->SetField(k.c_str(), v.c_str());
    if (layer->CreateFeature(feature.get()) != OGRERR_NONE) {
      return absl::InternalError(errors.Errors());
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<std::pair<double, double>> Carry(const std::string& from, const std::string& to,
                                                double x, double y) {
  auto a = SpatialReferenceFrom(from);
  if (!a.ok()) return a.status();
  auto b = SpatialReferenceFrom(to);
  if (!b.ok()) return b.status();
  auto ct = TransformationBetween(**a, **b);
  if (!ct.ok()) return ct.status();
  if (!(*ct)->Transform(1, &x, &y)) return absl::InternalError("transform failed");
  return std::pair{x, y};
}

std::pair<int, int> CellOfLatLon(const ImportedMap& map, double lat, double lon) {
  auto frame = FrameOfMap(map.header);
  if (!frame.ok()) return {-1, -1};
  auto xy = frame->ToLocal(LatLon{lat, lon});
  if (!xy.ok()) return {-1, -1};
  const MapHeader& h = map.header;
  const int i = static_cast<int>(std::floor((xy->x - h.x0) / h.res));
  const int j = static_cast<int>(std::floor((xy->y - h.y0) / h.res));
  if (i < 0 || j < 0 || i >= h.nx || j >= h.ny) return {-1, -1};
  return {i, j};
}

absl::StatusOr<std::string> RealGeodataDir() {
  static const absl::StatusOr<std::string>* result = [] {
    const std::string cache = std::string(RISKPLAN_BIN_DIR) + "/../geodata";
    const std::string command = absl::StrCat("bash '", RISKPLAN_SOURCE_DIR,
                                             "/scripts/fetch-geodata.sh' '", cache, "' 2>&1");
    FILE* pipe = popen(command.c_str(), "r");
    std::string output;
    if (pipe != nullptr) {
      char buffer[4096];
      size_t n = 0;
      while ((n = fread(buffer, 1, sizeof buffer, pipe)) > 0) output.append(buffer, n);
    }
    const int status = pipe == nullptr ? -1 : pclose(pipe);
    if (status != 0) {
      return new absl::StatusOr<std::string>(absl::UnavailableError(absl::StrCat(
          "scripts/fetch-geodata.sh could not fetch r-cran-terra and r-cran-satellite with "
          "apt-get download (the tests need them and do not skip): ",
          output)));
    }
    std::string dir(absl::StripTrailingAsciiWhitespace(output));
    if (const size_t nl = dir.rfind('\n'); nl != std::string::npos) dir = dir.substr(nl + 1);
    return new absl::StatusOr<std::string>(dir);
  }();
  return *result;
}

}  // namespace riskplan::geo::testing
