#include "geo/raster_input.h"

#include <gdal.h>
#include <gdal_priv.h>
#include <gdal_utils.h>
#include <ogr_geometry.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "geo/grid_rasterize.h"

namespace riskplan::geo {
namespace {

// Points per edge of an input's outline when it is carried into the frame.
constexpr int kOutlinePoints = 256;

std::string MaskText(GDALRasterBand* band) {
  const int flags = band->GetMaskFlags();
  if (flags & GMF_NODATA) {
    int has = 0;
    const double nodata = band->GetNoDataValue(&has);
    return absl::StrFormat("nodata value %.9g", nodata);
  }
  if (flags & GMF_ALPHA) return "alpha band";
  if (flags & GMF_PER_DATASET) return "mask band";
  return "all valid";
}

// The georeferenced point of pixel coordinates (p, l).
void PixelToGeo(const double gt[6], double p, double l, double* x, double* y) {
  *x = gt[0] + p * gt[1] + l * gt[2];
  *y = gt[3] + p * gt[4] + l * gt[5];
}

}  // namespace

const char* ResamplingName(Resampling r) {
  switch (r) {
    case Resampling::kBilinear:
      return "bilinear";
    case Resampling::kSum:
      return "sum";
    case Resampling::kAverage:
      return "average";
    case Resampling::kNearest:
      return "near";
    case Resampling::kMode:
      return "mode";
  }
  return "near";
}

std::string RasterInput::Label() const {
  return absl::StrFormat("layer '%s', input '%s'", layer, path);
}

std::string RasterInput::Summary() const {
  std::string text =
      absl::StrFormat("%s, %s, %d x %d pixels", driver, CrsShortName(srs.get()), width, height);
  if (has_geotransform) {
    const double sx = std::hypot(geotransform[1], geotransform[4]);
    const double sy = std::hypot(geotransform[2], geotransform[5]);
    absl::StrAppend(&text, absl::StrFormat(" of %.9g x %.9g %s", sx, sy,
                                           IsGeographic(*srs) ? "deg" : "CRS units"));
    if (geotransform[2] != 0.0 || geotransform[4] != 0.0) absl::StrAppend(&text, ", rotated");
  } else {
    absl::StrAppend(&text, ", placed by GCPs");
  }
  absl::StrAppend(&text, ", ", mask);
  if (!area_or_point.empty()) absl::StrAppend(&text, ", pixel is ", area_or_point);
  return text;
}

absl::StatusOr<RasterInput> OpenRasterInput(const std::string& layer, const std::string& path) {
  EnsureGdalRegistered();
  RasterInput in;
  in.layer = layer;
  in.path = path;
  if (IsRemotePath(path)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s: not a local file; an import reads no network (download it first)", in.Label()));
  }
  if (absl::Status s = CheckReadable(in.Label(), path); !s.ok()) return s;
  GdalErrorCapture errors;
  // GDAL_OF_VERBOSE_ERROR: without it GDAL says nothing when no driver takes
  // the file, and the refusal would have no reason.
  in.dataset.reset(GDALDataset::Open(path.c_str(),
                                     GDAL_OF_RASTER | GDAL_OF_READONLY | GDAL_OF_VERBOSE_ERROR));
  if (in.dataset == nullptr) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s: GDAL cannot open it as a raster: %s", in.Label(), errors.Errors()));
  }
  GDALDataset& ds = *in.dataset;
  in.driver = ds.GetDriver() != nullptr ? ds.GetDriver()->GetDescription() : "unknown";
  in.width = ds.GetRasterXSize();
  in.height = ds.GetRasterYSize();
  in.bands = ds.GetRasterCount();
  if (in.bands < 1 || in.width < 1 || in.height < 1) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s: the raster has no band or no pixel", in.Label()));
  }
  in.has_geotransform = ds.GetGeoTransform(in.geotransform) == CE_None;
  const OGRSpatialReference* srs = ds.GetSpatialRef();
  if (!in.has_geotransform) {
    if (ds.GetGCPCount() < 3) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "%s: the raster is not georeferenced (no geotransform and fewer than 3 GCPs)",
          in.Label()));
    }
    srs = ds.GetGCPSpatialRef();
  }
  if (srs == nullptr || srs->IsEmpty()) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s: the raster has no CRS; assign one first, e.g. gdal_translate -a_srs EPSG:XXXX",
        in.Label()));
  }
  in.srs = GisOrderCopy(*srs);
  const char* aop = ds.GetMetadataItem(GDALMD_AREA_OR_POINT);
  in.area_or_point = aop == nullptr ? "" : aop;
  in.mask = MaskText(ds.GetRasterBand(1));
  return in;
}

absl::StatusOr<std::vector<double>> WarpOntoGrid(const RasterInput& input, const TargetGrid& grid,
                                                 Resampling resampling, int threads) {
  auto frame_srs = SpatialReferenceFrom(grid.frame.proj_definition());
  if (!frame_srs.ok()) return frame_srs.status();
  // The warp writes straight into the vector returned (a MEM band over its
  // buffer), north row first; cells no source pixel reaches keep the NaN.
  std::vector<double> values(static_cast<size_t>(grid.cells()),
                             std::numeric_limits<double>::quiet_NaN());
  auto dst = CreateMemRaster(grid.nx, grid.ny, 0, GDT_Float64, grid.frame.x0(),
                             grid.frame.y0() + grid.height_m(), grid.res_m, **frame_srs);
  if (!dst.ok()) {
    return absl::Status(dst.status().code(),
                        absl::StrCat(input.Label(), ": ", dst.status().message()));
  }
  const std::string pointer = absl::StrFormat("DATAPOINTER=%p", static_cast<void*>(values.data()));
  const char* band_options[] = {pointer.c_str(), nullptr};
  if ((*dst)->AddBand(GDT_Float64, const_cast<char**>(band_options)) != CE_None) {
    return absl::InternalError(
        absl::StrFormat("%s: cannot make the warp's destination band", input.Label()));
  }
  (*dst)->GetRasterBand(1)->SetNoDataValue(std::numeric_limits<double>::quiet_NaN());

  // The warp runs on GDAL's threads too (-multi reads the source on one):
  // their messages must reach the refusal as well.
  GdalErrorCapture errors(GdalErrorCapture::Threads::kWithGdalWorkers);
  GDALDatasetH source = GDALDataset::ToHandle(input.dataset.get());
  // GDALWarp warps every band into a destination of as many: a VRT of band 1
  // alone (no copy of the pixels) stands in for a multi-band input.
  GDALDatasetUniquePtr band1;
  if (input.bands > 1) {
    const char* argv[] = {"-of", "VRT", "-b", "1", nullptr};
    GDALTranslateOptions* t = GDALTranslateOptionsNew(const_cast<char**>(argv), nullptr);
    band1.reset(GDALDataset::FromHandle(GDALTranslate("", source, t, nullptr)));
    GDALTranslateOptionsFree(t);
    if (band1 == nullptr) {
      return absl::InvalidArgumentError(
          absl::StrFormat("%s: cannot select band 1: %s", input.Label(), errors.Errors()));
    }
    source = GDALDataset::ToHandle(band1.get());
  }
  const std::string threads_text = absl::StrCat("NUM_THREADS=", threads < 1 ? 1 : threads);
  // -et: the approximate transformer's error, in destination pixels (GDAL's
  // default is 0.125); -wm: the warp's working memory in MB; INIT_DEST=NO_DATA:
  // cells no source pixel reaches stay NaN, not 0, so that they are refused
  // or filled as missing (docs/geodata.md, "Coverage").
  const char* argv[] = {
      "-r",  ResamplingName(resampling), "-et",    "0.05", "-wm", "256", "-wo", "INIT_DEST=NO_DATA",
      "-wo", threads_text.c_str(),       "-multi", nullptr};
  GDALWarpAppOptions* options = GDALWarpAppOptionsNew(const_cast<char**>(argv), nullptr);
  if (options == nullptr) {
    return absl::InternalError(
        absl::StrFormat("%s: GDAL refuses the warp options: %s", input.Label(), errors.Errors()));
  }
  int usage_error = 0;
  GDALDatasetH warped =
      GDALWarp(nullptr, GDALDataset::ToHandle(dst->get()), 1, &source, options, &usage_error);
  GDALWarpAppOptionsFree(options);
  if (warped == nullptr) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s: GDAL cannot warp it onto the map's grid: %s", input.Label(), errors.Errors()));
  }

  // The band must not outlive the buffer it writes to.
  dst->reset();
  // GDAL's rasters are north-up; bundles store the southernmost row first.
  FlipRows(grid.nx, grid.ny, values);
  int has_scale = 0, has_offset = 0;
  GDALRasterBand* in_band = input.dataset->GetRasterBand(1);
  const double scale = in_band->GetScale(&has_scale);
  const double offset = in_band->GetOffset(&has_offset);
  if ((has_scale && scale != 1.0) || (has_offset && offset != 0.0)) {
    const double s = has_scale ? scale : 1.0, o = has_offset ? offset : 0.0;
    for (double& v : values) v = v * s + o;
  }
  return values;
}

absl::StatusOr<std::vector<uint8_t>> InputFootprint(const RasterInput& input,
                                                    const TargetGrid& grid) {
  auto frame_srs = SpatialReferenceFrom(grid.frame.proj_definition());
  if (!frame_srs.ok()) return frame_srs.status();
  if (!input.has_geotransform) {
    // Placed by GCPs: no simple outline; every cell counts as inside, so a gap
    // is reported as missing data rather than as a gap in coverage.
    return std::vector<uint8_t>(static_cast<size_t>(grid.cells()), 1);
  }
  auto ct = TransformationBetween(*input.srs, **frame_srs);
  if (!ct.ok())
    return absl::InvalidArgumentError(absl::StrCat(input.Label(), ": ", ct.status().message()));
  OGRLinearRing ring;
  const double w = input.width, h = input.height;
  const double corners[5][2] = {{0, 0}, {w, 0}, {w, h}, {0, h}, {0, 0}};
  for (int e = 0; e < 4; ++e) {
    for (int k = 0; k < kOutlinePoints; ++k) {
      const double t = static_cast<double>(k) / kOutlinePoints;
      double x = 0, y = 0;
      PixelToGeo(input.geotransform, corners[e][0] + t * (corners[e + 1][0] - corners[e][0]),
                 corners[e][1] + t * (corners[e + 1][1] - corners[e][1]), &x, &y);
      // A point the frame cannot hold (the far side of the Earth for a global
      // raster) is left out of the outline.
      if ((*ct)->Transform(1, &x, &y) && std::isfinite(x) && std::isfinite(y)) ring.addPoint(x, y);
    }
  }
  ring.closeRings();
  OGRPolygon outline;
  outline.addRing(&ring);
  return BurnMask(grid, {&outline}, /*all_touched=*/false);
}

absl::StatusOr<double> PixelSizeNearMap(const RasterInput& input, const TargetGrid& grid) {
  if (!input.has_geotransform) return grid.res_m;
  auto frame_srs = SpatialReferenceFrom(grid.frame.proj_definition());
  if (!frame_srs.ok()) return frame_srs.status();
  auto to_input = TransformationBetween(**frame_srs, *input.srs);
  if (!to_input.ok()) return to_input.status();
  auto to_frame = TransformationBetween(*input.srs, **frame_srs);
  if (!to_frame.ok()) return to_frame.status();
  double cx = grid.frame.x0() + grid.width_m() / 2, cy = grid.frame.y0() + grid.height_m() / 2;
  if (!(*to_input)->Transform(1, &cx, &cy)) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s: the map's centre has no place in the input's CRS", input.Label()));
  }
  double gt[6], inverse[6];
  std::copy(input.geotransform, input.geotransform + 6, gt);
  if (!GDALInvGeoTransform(gt, inverse)) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s: the geotransform cannot be inverted", input.Label()));
  }
  const double p = inverse[0] + cx * inverse[1] + cy * inverse[2];
  const double l = inverse[3] + cx * inverse[4] + cy * inverse[5];
  double xs[3], ys[3];
  PixelToGeo(input.geotransform, p, l, &xs[0], &ys[0]);
  PixelToGeo(input.geotransform, p + 1, l, &xs[1], &ys[1]);
  PixelToGeo(input.geotransform, p, l + 1, &xs[2], &ys[2]);
  if (!(*to_frame)->Transform(3, xs, ys)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s: the pixels at the map's centre have no place in the map's frame", input.Label()));
  }
  return 0.5 *
         (std::hypot(xs[1] - xs[0], ys[1] - ys[0]) + std::hypot(xs[2] - xs[0], ys[2] - ys[0]));
}

}  // namespace riskplan::geo
