// Vector geometries burnt into the map's cells with GDAL's rasterizer, and
// the row flip between GDAL's north-up rasters and the map's south-to-north
// rows. Geometries are in the grid's local frame (metres).
#ifndef RISKPLAN_GEO_GRID_RASTERIZE_H_
#define RISKPLAN_GEO_GRID_RASTERIZE_H_

#include <ogr_geometry.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "geo/target_grid.h"

namespace riskplan::geo {

// Reverses the order of the ny rows of nx values: north-up <-> south-up.
// REQUIRES: values.size() == nx * ny.
template <typename T>
void FlipRows(int nx, int ny, std::vector<T>& values) {
  for (int j = 0; j < ny / 2; ++j) {
    auto top = values.begin() + static_cast<std::ptrdiff_t>(j) * nx;
    auto bottom = values.begin() + static_cast<std::ptrdiff_t>(ny - 1 - j) * nx;
    std::swap_ranges(top, top + nx, bottom);
  }
}

// 1 in every cell a geometry covers, else 0. With all_touched, every cell a
// geometry touches (GDAL's ALL_TOUCHED: the conservative choice for no-fly
// zones); without, every cell whose centre is inside a polygon (and the cells
// a point or line passes through). South row first.
absl::StatusOr<std::vector<uint8_t>> BurnMask(const TargetGrid& grid,
                                              const std::vector<const OGRGeometry*>& geometries,
                                              bool all_touched);

// ids[k] (> 0) burnt for geometries[k] into an Int32 raster of the grid's
// cells (0 where none: the centre rule above); a later geometry overwrites an
// earlier one. South row first. REQUIRES: ids.size() == geometries.size().
absl::StatusOr<std::vector<int32_t>> BurnIds(const TargetGrid& grid,
                                             const std::vector<const OGRGeometry*>& geometries,
                                             const std::vector<int32_t>& ids);

// The share of each cell's area that the (polygonal) geometries cover, in
// [0, 1], estimated on k x k sub-cells per cell (the centre rule on each),
// with k the largest of 1..max_k for which nx*ny*k*k stays within
// max_subcells; *k_used tells which. South row first.
absl::StatusOr<std::vector<float>> CoverageShare(const TargetGrid& grid,
                                                 const std::vector<const OGRGeometry*>& geometries,
                                                 int max_k, int64_t max_subcells, int* k_used);

}  // namespace riskplan::geo

#endif  // RISKPLAN_GEO_GRID_RASTERIZE_H_
