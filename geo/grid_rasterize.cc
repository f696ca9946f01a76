#include "geo/grid_rasterize.h"

#include <gdal_alg.h>
#include <gdal_priv.h>
#include <ogr_geometry.h>

#include <cstdint>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_format.h"
#include "core/base/check.h"
#include "geo/gdal_util.h"

namespace riskplan::geo {
namespace {

template <typename T>
constexpr GDALDataType DataTypeOf();
template <>
constexpr GDALDataType DataTypeOf<uint8_t>() {
  return GDT_Byte;
}
template <>
constexpr GDALDataType DataTypeOf<int32_t>() {
  return GDT_Int32;
}

// Burns `values` for `geometries` into a zero raster of nx x ny cells of side
// `res` over the grid's area; returns its cells north row first.
template <typename T>
absl::StatusOr<std::vector<T>> Burn(const TargetGrid& grid, int nx, int ny, double res,
                                    const std::vector<const OGRGeometry*>& geometries,
                                    const std::vector<double>& values, bool all_touched) {
  RISKPLAN_DCHECK(values.size() == geometries.size());
  auto frame_srs = SpatialReferenceFrom(grid.frame.proj_definition());
  if (!frame_srs.ok()) return frame_srs.status();
  auto ds = CreateMemRaster(nx, ny, 1, DataTypeOf<T>(), grid.frame.x0(),
                            grid.frame.y0() + grid.height_m(), res, **frame_srs);
  if (!ds.ok()) return ds.status();
  std::vector<T> cells(static_cast<size_t>(nx) * static_cast<size_t>(ny), T{0});
  if (!geometries.empty()) {
    GdalErrorCapture errors;
    std::vector<OGRGeometryH> handles;
    handles.reserve(geometries.size());
    for (const OGRGeometry* g : geometries) {
      handles.push_back(OGRGeometry::ToHandle(const_cast<OGRGeometry*>(g)));
    }
    const int band = 1;
    const char* options[] = {all_touched ? "ALL_TOUCHED=TRUE" : "ALL_TOUCHED=FALSE", nullptr};
    if (GDALRasterizeGeometries(GDALDataset::ToHandle(ds->get()), 1, &band,
                                static_cast<int>(handles.size()), handles.data(), nullptr, nullptr,
                                values.data(), options, nullptr, nullptr) != CE_None) {
      return absl::InternalError(absl::StrFormat("GDAL cannot rasterize %d geometries: %s",
                                                 handles.size(), errors.Errors()));
    }
    if ((*ds)->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, nx, ny, cells.data(), nx, ny,
                                          DataTypeOf<T>(), 0, 0, nullptr) != CE_None) {
      return absl::InternalError(
          absl::StrFormat("cannot read a rasterized layer: %s", errors.Errors()));
    }
  }
  return cells;
}

}  // namespace

absl::StatusOr<std::vector<uint8_t>> BurnMask(const TargetGrid& grid,
                                              const std::vector<const OGRGeometry*>& geometries,
                                              bool all_touched) {
  auto cells = Burn<uint8_t>(grid, grid.nx, grid.ny, grid.res_m, geometries,
                             std::vector<double>(geometries.size(), 1.0), all_touched);
  if (!cells.ok()) return cells.status();
  FlipRows(grid.nx, grid.ny, *cells);
  return cells;
}

absl::StatusOr<std::vector<int32_t>> BurnIds(const TargetGrid& grid,
                                             const std::vector<const OGRGeometry*>& geometries,
                                             const std::vector<int32_t>& ids) {
  RISKPLAN_DCHECK(ids.size() == geometries.size());
  auto cells = Burn<int32_t>(grid, grid.nx, grid.ny, grid.res_m, geometries,
                             std::vector<double>(ids.begin(), ids.end()), false);
  if (!cells.ok()) return cells.status();
  FlipRows(grid.nx, grid.ny, *cells);
  return cells;
}

absl::StatusOr<std::vector<float>> CoverageShare(const TargetGrid& grid,
                                                 const std::vector<const OGRGeometry*>& geometries,
                                                 int max_k, int64_t max_subcells, int* k_used) {
  int k = max_k < 1 ? 1 : max_k;
  while (k > 1 && grid.cells() * k * k > max_subcells) --k;
  *k_used = k;
  const int snx = grid.nx * k, sny = grid.ny * k;
  auto sub = Burn<uint8_t>(grid, snx, sny, grid.res_m / k, geometries,
                           std::vector<double>(geometries.size(), 1.0), false);
  if (!sub.ok()) return sub.status();
  std::vector<float> share(static_cast<size_t>(grid.cells()), 0.0f);
  const float unit = 1.0f / static_cast<float>(k * k);
  for (int r = 0; r < sny; ++r) {
    // Sub-row r (north first) lies in map row ny-1-r/k.
    float* row = share.data() + static_cast<size_t>(grid.ny - 1 - r / k) * grid.nx;
    const uint8_t* in = sub->data() + static_cast<size_t>(r) * snx;
    for (int c = 0; c < snx; ++c) {
      if (in[c] != 0) row[c / k] += unit;
    }
  }
  // k^2 float additions of 1/k^2 may round to a little more than 1.
  for (float& s : share) s = s > 1.0f ? 1.0f : s;
  return share;
}

}  // namespace riskplan::geo
