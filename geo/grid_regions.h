// Regions of a map's grid, for landing sites: connected fields, how deep
// inside its region each cell lies, and the deepest cell of each region.
// Pure grid logic (no GDAL). Grids are nx x ny, south row first.
#ifndef RISKPLAN_GEO_GRID_REGIONS_H_
#define RISKPLAN_GEO_GRID_REGIONS_H_

#include <cstdint>
#include <vector>

namespace riskplan::geo {

// Labels the 4-connected components of the nonzero cells of `mask`: 1, 2, ...
// in order of each component's first cell (south row first); 0 elsewhere.
// Returns the number of components in *count.
std::vector<int32_t> LabelComponents(const std::vector<uint8_t>& mask, int nx, int ny,
                                     int32_t* count);

// For each cell with label > 0, its chamfer distance (3-4 weights, divided by
// 3: about cells) to the nearest cell with another label, or to the map's
// edge; 0 for label 0. REQUIRES: labels.size() == nx*ny.
std::vector<float> DepthInside(const std::vector<int32_t>& labels, int nx, int ny);

struct Region {
  int32_t label = 0;
  int64_t cells = 0;
  int deepest_i = 0;  // the cell of greatest depth (of several, the one nearest their mean)
  int deepest_j = 0;
  float depth = 0.0f;
};

// Every label 1..count with its size and deepest cell, in label order;
// regions whose every cell is `excluded` (nonzero) are left out, and an
// excluded cell is never a deepest cell. `excluded` may be empty.
std::vector<Region> Regions(const std::vector<int32_t>& labels, int32_t count, int nx, int ny,
                            const std::vector<uint8_t>& excluded);

}  // namespace riskplan::geo

#endif  // RISKPLAN_GEO_GRID_REGIONS_H_
