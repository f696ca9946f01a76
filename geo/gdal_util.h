// What every GDAL/OGR user in geo/ shares: registering the drivers once,
// turning GDAL's error stack into absl::Status messages, and spatial
// references that always take x = longitude / easting (GIS order).
//
// GDAL types appear in this header, so only geo/ sources include it; the
// importer's public interface (geo/map_importer.h) has none.
#ifndef RISKPLAN_GEO_GDAL_UTIL_H_
#define RISKPLAN_GEO_GDAL_UTIL_H_

#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace riskplan::geo {

// Registers GDAL's drivers once per process and sets what the importer relies
// on: PROJ never fetches grids from the network (PROJ_NETWORK=OFF), and the GeoTIFF
// driver honouring AREA_OR_POINT=Point (GTIFF_POINT_GEO_IGNORE=FALSE, GDAL's
// default, set explicitly so an environment cannot change it). Thread-safe.
void EnsureGdalRegistered();

// While alive, collects the messages GDAL reports on this thread instead of
// printing them to stderr (GDAL's handler stack is thread-local). Keeps the
// first kMaxMessages failures and warnings and counts the rest: one call can
// report a failure per point (a transformation of millions of points), and
// the messages must not grow without bound. Not copyable.
//
// GDAL's own worker threads (a warp with -multi reads the source on one,
// NUM_THREADS computes on others) have no handler of ours: their messages go
// to GDAL's process-wide handler, which EnsureGdalRegistered replaces with
// one that hands them to every capture alive made with kWithGdalWorkers (to
// stderr, as GDAL's default does, when there is none). So a capture around a
// multi-threaded GDAL call gets GDAL's words from every thread of it. With
// two such calls at once in one process each would get both's messages; an
// import runs one at a time (geo/map_importer.h).
class GdalErrorCapture {
 public:
  static constexpr size_t kMaxMessages = 16;
  enum class Threads { kThisThread, kWithGdalWorkers };

  explicit GdalErrorCapture(Threads threads = Threads::kThisThread);
  ~GdalErrorCapture();
  GdalErrorCapture(const GdalErrorCapture&) = delete;
  GdalErrorCapture& operator=(const GdalErrorCapture&) = delete;

  // Failures (CE_Failure, CE_Fatal) joined by "; ", then "; and N more" for
  // those not kept, or `fallback` when GDAL reported none.
  std::string Errors(const std::string& fallback = "no message from GDAL") const;
  // The warnings kept (at most kMaxMessages), and how many there were.
  std::vector<std::string> warnings() const {
    std::lock_guard<std::mutex> lock(mu_);
    return warnings_;
  }
  uint64_t warning_count() const {
    std::lock_guard<std::mutex> lock(mu_);
    return warning_count_;
  }
  uint64_t error_count() const {
    std::lock_guard<std::mutex> lock(mu_);
    return error_count_;
  }

 private:
  static void CPL_STDCALL Handler(CPLErr level, CPLErrorNum number, const char* message);
  static void CPL_STDCALL ProcessHandler(CPLErr level, CPLErrorNum number, const char* message);
  void Keep(CPLErr level, const char* message);
  friend void EnsureGdalRegistered();

  const Threads threads_;
  mutable std::mutex mu_;  // the workers' messages arrive on their threads
  std::vector<std::string> errors_;
  std::vector<std::string> warnings_;
  uint64_t error_count_ = 0;
  uint64_t warning_count_ = 0;
};

struct SpatialReferenceDeleter {
  void operator()(OGRSpatialReference* srs) const { srs->Release(); }
};
using SpatialReferencePtr = std::unique_ptr<OGRSpatialReference, SpatialReferenceDeleter>;

struct CoordinateTransformationDeleter {
  void operator()(OGRCoordinateTransformation* ct) const {
    OGRCoordinateTransformation::DestroyCT(ct);
  }
};
using CoordinateTransformationPtr =
    std::unique_ptr<OGRCoordinateTransformation, CoordinateTransformationDeleter>;

// True for a path GDAL would read over the network (/vsicurl/, /vsis3/, ...,
// http://, https://, ftp://): the importer reads local files only.
bool IsRemotePath(const std::string& path);

// NotFound, "LABEL: cannot read it: No such file or directory" (the
// system's words), when `path` does not exist or, as a file, cannot be
// opened for reading; OK otherwise (GDAL then says what else is wrong).
absl::Status CheckReadable(const std::string& label, const std::string& path);

// A spatial reference from any text GDAL accepts ("EPSG:4326", a PROJ string,
// WKT), with OAMS_TRADITIONAL_GIS_ORDER: x is longitude (or easting) and y
// latitude (or northing) whatever the CRS's official axis order. EPSG:4326's
// official order is latitude first; reading it that way would swap every
// coordinate. InvalidArgument naming `text` if GDAL refuses it.
absl::StatusOr<SpatialReferencePtr> SpatialReferenceFrom(const std::string& text);

// A copy of `srs` with OAMS_TRADITIONAL_GIS_ORDER (see above).
SpatialReferencePtr GisOrderCopy(const OGRSpatialReference& srs);

// WGS84 geographic, longitude first (GIS order).
SpatialReferencePtr Wgs84Lonlat();

// A transformation between two spatial references (each in GIS order), or
// InvalidArgument naming both.
absl::StatusOr<CoordinateTransformationPtr> TransformationBetween(const OGRSpatialReference& from,
                                                                  const OGRSpatialReference& to);

// A short name for a CRS: "EPSG:32632" when it has an authority code, else
// its name, e.g. "unknown (Oblique Stereographic)"; "none" for nullptr.
std::string CrsShortName(const OGRSpatialReference* srs);

// The CRS as one-line WKT2 (for provenance), or "" when it cannot be written.
std::string CrsWkt(const OGRSpatialReference& srs);

// True when the CRS is geographic (degrees).
bool IsGeographic(const OGRSpatialReference& srs);

// An in-memory raster of nx x ny cells of `type` whose geotransform puts its
// top-left corner at (x_min, y_max) with square cells of side `res` (north up,
// as every GDAL raster), in `srs`; `bands` bands. Internal if the MEM driver
// fails.
absl::StatusOr<GDALDatasetUniquePtr> CreateMemRaster(int nx, int ny, int bands, GDALDataType type,
                                                     double x_min, double y_max, double res,
                                                     const OGRSpatialReference& srs);

}  // namespace riskplan::geo

#endif  // RISKPLAN_GEO_GDAL_UTIL_H_
