// Raster inputs of an import (a DEM, a population raster, a land-cover
// raster): opened, described, and warped by GDAL onto the target grid.
#ifndef RISKPLAN_GEO_RASTER_INPUT_H_
#define RISKPLAN_GEO_RASTER_INPUT_H_

#include <gdal_priv.h>

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "geo/gdal_util.h"
#include "geo/target_grid.h"

namespace riskplan::geo {

// How a layer's values are carried from the input's pixels to the map's cells
// (GDAL's warp kernels).
enum class Resampling {
  kBilinear,  // terrain: a smooth surface sampled at the cell centre
  kSum,       // people per pixel: each cell gets the people of the part of each pixel it covers
  kAverage,   // densities: the area-weighted mean of the pixels a cell covers
  kNearest,   // classes, cells finer than the pixels: the pixel under the cell centre
  kMode,      // classes, cells coarser than the pixels: the most frequent class
};
const char* ResamplingName(Resampling r);  // GDAL's name: "bilinear", "sum", ...

// One open raster input. `layer` names the map layer it feeds ("terrain",
// "population", "land cover"), for messages.
struct RasterInput {
  std::string layer;
  std::string path;
  GDALDatasetUniquePtr dataset;
  SpatialReferencePtr srs;  // GIS order; never null once opened
  std::string driver;       // GDAL's short name, e.g. "GTiff", "SRTMHGT"
  int width = 0;
  int height = 0;
  int bands = 0;
  bool has_geotransform = false;
  double geotransform[6] = {0, 1, 0, 0, 0, 1};
  // GDAL's AREA_OR_POINT metadata ("Area", "Point", or "" when absent). GDAL
  // already shifts the geotransform of a pixel-is-point GeoTIFF or SRTM .hgt
  // by half a pixel, so the geotransform always gives pixel corners; this is
  // kept for provenance.
  std::string area_or_point;
  // Where band 1's validity comes from: "all valid", "nodata value V", "mask
  // band", "alpha band".
  std::string mask;

  // "layer 'terrain', input 'dem.tif'": the prefix of every message about it.
  std::string Label() const;
  // "GTiff, EPSG:32632, 41 x 41 pixels of 30 x 30 m, nodata value -32768, area"
  std::string Summary() const;
};

// Opens `path` as a raster for `layer`. Refusals (InvalidArgument, naming the
// layer and the input): a path GDAL cannot open as a raster, not a local
// file (a /vsicurl/ or http address: an import never reads the network), no
// band, no CRS, no geotransform (nor GCPs).
absl::StatusOr<RasterInput> OpenRasterInput(const std::string& layer, const std::string& path);

// Band 1 of `input` warped onto `grid` (GDALWarp into an in-memory raster in
// the grid's frame), then flipped from GDAL's north-up rows into the map's
// south-to-north rows: value (i, j) is at index j*nx + i. Cells with no data
// (outside the input, or masked: nodata value, mask band or alpha, as
// GetMaskBand() reports) are NaN. The band's scale and offset are applied.
// `threads` >= 1 warp threads.
absl::StatusOr<std::vector<double>> WarpOntoGrid(const RasterInput& input, const TargetGrid& grid,
                                                 Resampling resampling, int threads);

// 1 for every cell whose centre lies inside the input's pixel extent (its
// outline followed through its geotransform, rotation included, into the
// grid's frame), else 0; south row first.
absl::StatusOr<std::vector<uint8_t>> InputFootprint(const RasterInput& input,
                                                    const TargetGrid& grid);

// The input's pixel size near the map's centre, in metres (the mean of its
// two sides, measured in the grid's frame).
absl::StatusOr<double> PixelSizeNearMap(const RasterInput& input, const TargetGrid& grid);

}  // namespace riskplan::geo

#endif  // RISKPLAN_GEO_RASTER_INPUT_H_
