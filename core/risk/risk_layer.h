// Full-map risk layers: the configuration risk M of every cell of a map, for
// users who want to see where flying is risky (riskplan-tool risk-layer).
//
// Geometry. A layer is a regular grid in the map's frame with the map's
// south-west corner (x0, y0) and cells of side stride * res: layer cell (c, r)
// covers the stride x stride block of map cells [c*stride, (c+1)*stride) x
// [r*stride, (r+1)*stride), i.e. [x0 + c*res_m, x0 + (c+1)*res_m) x
// [y0 + r*res_m, y0 + (r+1)*res_m) with res_m = stride * res. Its value is M
// at the centre of that square, (x0 + (c+0.5)*res_m, y0 + (r+0.5)*res_m), so a
// raster written from (x0, y0, res_m) puts every value where it was computed.
// The layer covers whole blocks only: when stride does not divide nx (ny), the
// last nx % stride columns at the east edge (ny % stride rows at the north
// edge) of the map are left out, so no layer cell reaches past the map.
// A layer may cover a window of the map instead (first_column, columns, ...
// below): the same geometry with the window's south-west cell as (0, 0) and
// its edges as the map's.
#ifndef RISKPLAN_CORE_RISK_RISK_LAYER_H_
#define RISKPLAN_CORE_RISK_RISK_LAYER_H_

#include <cstdint>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/cancellation.h"
#include "core/risk/risk_model.h"

namespace riskplan {

struct RiskLayerOptions {
  // The aircraft flies this high above the terrain of the map cell that
  // contains each layer cell's centre (spec section 3 step 1: h = height_agl_m).
  double height_agl_m = 100.0;
  // Heading in radians; NaN: the maximum of M over all heading bins.
  double heading_rad = 0.0;
  int threads = 1;  // rows are split between this many threads
  // Side of a layer cell in map cells (1: one value per map cell), in
  // [1, min(columns, rows)] of the window (ComputeRiskLayer refuses others).
  int stride = 1;
  // The window of map cells the layer covers: columns [first_column,
  // first_column + columns) and rows [first_row, first_row + rows); 0
  // columns (rows) means up to the map's east (north) edge. Inside the map.
  int first_column = 0;
  int first_row = 0;
  int columns = 0;
  int rows = 0;
  // Polled before every row: once reached, ComputeRiskLayer stops and
  // returns Cancelled.
  StopCondition stop{};
};

struct RiskLayer {
  int nx = 0;          // columns: map columns / stride, rounded down
  int ny = 0;          // rows: map rows / stride, rounded down
  double x0 = 0.0;     // m, south-west corner of the layer (= the map's)
  double y0 = 0.0;     // m
  double res_m = 0.0;  // m, cell side of the layer (stride * map res)
  // M per layer cell (expected casualties given a failure at the cell's
  // centre), row-major, row 0 south. NaN (NODATA) where M is undefined for
  // the heading considered, or (maximum over headings) for any heading bin:
  // along the map's edges, a band as wide as the impact window's reach at
  // that height (spec version 2: the ground outside is unknown); and at
  // h <= 0, which for a positive height happens
  // only where terrain + height_agl_m rounds back to the terrain in double
  // (terrain of about 1e6 m and heights below 1e-10 m).
  std::vector<double> risk;
  int64_t evaluations = 0;  // configuration risks asked for

  // Centre of column c and of row r: where their values were computed.
  double centre_x(int c) const { return x0 + (c + 0.5) * res_m; }
  double centre_y(int r) const { return y0 + (r + 0.5) * res_m; }
  double at(int c, int r) const { return risk[static_cast<size_t>(r) * nx + c]; }
};

// Computes the layer described above. Deterministic whatever the thread count.
// Errors (InvalidArgument): height not finite and > 0, infinite heading,
// threads outside [1, 256], a window not inside the map, stride < 1 or larger
// than the window's smaller side; Cancelled once options.stop is reached.
// The work is layer columns * rows configuration risks (times the heading
// bins for the maximum): a caller serving requests bounds it before calling
// (LayerCells).
absl::StatusOr<RiskLayer> ComputeRiskLayer(const RiskModel& model, const RiskLayerOptions& options);

// The columns and rows of the layer ComputeRiskLayer would compute for `map`
// and `options`, or its error (the same checks, nothing computed).
struct LayerShape {
  int nx = 0;
  int ny = 0;
};
absl::StatusOr<LayerShape> LayerCells(const RiskMap& map, const RiskLayerOptions& options);

}  // namespace riskplan

#endif  // RISKPLAN_CORE_RISK_RISK_LAYER_H_
