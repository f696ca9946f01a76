#include "geo/gdal_util.h"

#include <cpl_conv.h>
#include <cpl_error.h>
#include <cpl_vsi.h>
#include <gdal.h>
#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include <cerrno>
#include <cstring>
#include <mutex>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"

namespace riskplan::geo {
namespace {

// The captures made with kWithGdalWorkers, alive now.
std::mutex& WorkerCapturesMutex() {
  static std::mutex mu;
  return mu;
}
std::vector<GdalErrorCapture*>& WorkerCaptures() {
  static std::vector<GdalErrorCapture*> captures;
  return captures;
}

}  // namespace

void EnsureGdalRegistered() {
  static std::once_flag once;
  std::call_once(once, [] {
    // No PROJ grid is fetched from the CDN: an import never depends on the
    // network (the importer also refuses inputs that are not local files).
    CPLSetConfigOption("PROJ_NETWORK", "OFF");
    // A GeoTIFF with AREA_OR_POINT=Point has its geotransform shifted by half
    // a pixel, so that a sample sits at its coordinates, not at its pixel's
    // corner (docs/geodata.md, "Pixel is point").
    CPLSetConfigOption("GTIFF_POINT_GEO_IGNORE", "FALSE");
    // Messages of threads without a handler of their own (GDAL's workers).
    CPLSetErrorHandler(&GdalErrorCapture::ProcessHandler);
    GDALAllRegister();
  });
}

bool IsRemotePath(const std::string& path) {
  for (const char* prefix :
       {"/vsicurl", "/vsis3", "/vsigs", "/vsiaz", "/vsiadls", "/vsioss", "/vsiswift", "/vsihdfs",
        "/vsiwebhdfs", "http://", "https://", "ftp://"}) {
    if (absl::StartsWith(path, prefix)) return true;
  }
  return false;
}

GdalErrorCapture::GdalErrorCapture(Threads threads) : threads_(threads) {
  CPLErrorReset();
  CPLPushErrorHandlerEx(&GdalErrorCapture::Handler, this);
  if (threads_ == Threads::kWithGdalWorkers) {
    EnsureGdalRegistered();
    std::lock_guard<std::mutex> lock(WorkerCapturesMutex());
    WorkerCaptures().push_back(this);
  }
}

GdalErrorCapture::~GdalErrorCapture() {
  CPLPopErrorHandler();
  if (threads_ == Threads::kWithGdalWorkers) {
    std::lock_guard<std::mutex> lock(WorkerCapturesMutex());
    std::erase(WorkerCaptures(), this);
  }
}

void GdalErrorCapture::Keep(CPLErr level, const char* message) {
  std::lock_guard<std::mutex> lock(mu_);
  const auto keep = [message](std::vector<std::string>& kept, uint64_t& count) {
    if (++count <= kMaxMessages) kept.emplace_back(message == nullptr ? "" : message);
  };
  if (level == CE_Failure || level == CE_Fatal) {
    keep(errors_, error_count_);
  } else if (level == CE_Warning) {
    keep(warnings_, warning_count_);
  }
}

void CPL_STDCALL GdalErrorCapture::Handler(CPLErr level, CPLErrorNum /*number*/,
                                           const char* message) {
  auto* self = static_cast<GdalErrorCapture*>(CPLGetErrorHandlerUserData());
  if (self == nullptr) return;
  self->Keep(level, message);
}

void CPL_STDCALL GdalErrorCapture::ProcessHandler(CPLErr level, CPLErrorNum number,
                                                  const char* message) {
  if (level == CE_Failure || level == CE_Fatal || level == CE_Warning) {
    std::lock_guard<std::mutex> lock(WorkerCapturesMutex());
    if (!WorkerCaptures().empty()) {
      for (GdalErrorCapture* capture : WorkerCaptures()) capture->Keep(level, message);
      return;
    }
  }
  CPLDefaultErrorHandler(level, number, message);
}

std::string GdalErrorCapture::Errors(const std::string& fallback) const {
  std::lock_guard<std::mutex> lock(mu_);
  if (errors_.empty()) return fallback;
  std::string text = absl::StrJoin(errors_, "; ");
  if (error_count_ > errors_.size()) absl::StrAppend(&text, "; and ", error_count_ - errors_.size(), " more");
  return text;
}

absl::Status CheckReadable(const std::string& label, const std::string& path) {
  VSIStatBufL st;
  errno = 0;
  if (VSIStatExL(path.c_str(), &st, VSI_STAT_EXISTS_FLAG | VSI_STAT_NATURE_FLAG) != 0) {
    return absl::NotFoundError(absl::StrFormat("%s: cannot read it: %s", label,
                                               errno != 0 ? std::strerror(errno) : "not found"));
  }
  if (VSI_ISREG(st.st_mode)) {
    errno = 0;
    VSILFILE* f = VSIFOpenL(path.c_str(), "rb");
    if (f == nullptr) {
      return absl::NotFoundError(absl::StrFormat(
          "%s: cannot read it: %s", label, errno != 0 ? std::strerror(errno) : "cannot open it"));
    }
    VSIFCloseL(f);
  }
  return absl::OkStatus();
}

absl::StatusOr<SpatialReferencePtr> SpatialReferenceFrom(const std::string& text) {
  EnsureGdalRegistered();
  GdalErrorCapture errors;
  SpatialReferencePtr srs(new OGRSpatialReference());
  if (srs->SetFromUserInput(text.c_str()) != OGRERR_NONE) {
    return absl::InvalidArgumentError(
        absl::StrFormat("'%s' is not a CRS GDAL knows: %s", text, errors.Errors()));
  }
  // EPSG:4326 officially lists latitude first; GDAL's rasters and OGR's
  // geometries hold longitude first, and so does every reference built here.
  srs->SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  return srs;
}

SpatialReferencePtr GisOrderCopy(const OGRSpatialReference& srs) {
  SpatialReferencePtr copy(srs.Clone());
  copy->SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  return copy;
}

SpatialReferencePtr Wgs84Lonlat() {
  SpatialReferencePtr srs(new OGRSpatialReference());
  srs->SetWellKnownGeogCS("WGS84");
  srs->SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  return srs;
}

absl::StatusOr<CoordinateTransformationPtr> TransformationBetween(const OGRSpatialReference& from,
                                                                  const OGRSpatialReference& to) {
  GdalErrorCapture errors;
  CoordinateTransformationPtr ct(OGRCreateCoordinateTransformation(&from, &to));
  if (ct == nullptr) {
    return absl::InvalidArgumentError(absl::StrFormat("no transformation from %s to %s: %s",
                                                      CrsShortName(&from), CrsShortName(&to),
                                                      errors.Errors()));
  }
  return ct;
}

std::string CrsShortName(const OGRSpatialReference* srs) {
  if (srs == nullptr) return "none";
  const char* authority = srs->GetAuthorityName(nullptr);
  const char* code = srs->GetAuthorityCode(nullptr);
  if (authority != nullptr && code != nullptr) return absl::StrCat(authority, ":", code);
  const char* name = srs->GetName();
  std::string text = name == nullptr ? "unnamed" : name;
  const char* method = srs->GetAttrValue("PROJECTION");
  if (method != nullptr) absl::StrAppend(&text, " (", method, ")");
  return text;
}

std::string CrsWkt(const OGRSpatialReference& srs) {
  char* wkt = nullptr;
  const char* options[] = {"FORMAT=WKT2_2018", "MULTILINE=NO", nullptr};
  if (srs.exportToWkt(&wkt, options) != OGRERR_NONE || wkt == nullptr) {
    CPLFree(wkt);
    return "";
  }
  std::string text(wkt);
  CPLFree(wkt);
  return text;
}

bool IsGeographic(const OGRSpatialReference& srs) { return srs.IsGeographic() != 0; }

absl::StatusOr<GDALDatasetUniquePtr> CreateMemRaster(int nx, int ny, int bands, GDALDataType type,
                                                     double x_min, double y_max, double res,
                                                     const OGRSpatialReference& srs) {
  EnsureGdalRegistered();
  GdalErrorCapture errors;
  GDALDriver* mem = GetGDALDriverManager()->GetDriverByName("MEM");
  if (mem == nullptr) return absl::InternalError("GDAL has no MEM driver");
  GDALDatasetUniquePtr ds(mem->Create("", nx, ny, bands, type, nullptr));
  if (ds == nullptr) {
    return absl::ResourceExhaustedError(absl::StrFormat(
        "cannot create an in-memory raster of %d x %d cells: %s", nx, ny, errors.Errors()));
  }
  double gt[6] = {x_min, res, 0.0, y_max, 0.0, -res};
  ds->SetGeoTransform(gt);
  ds->SetSpatialRef(&srs);
  return ds;
}

}  // namespace riskplan::geo
