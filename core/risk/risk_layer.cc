#include "core/risk/risk_layer.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <thread>

#include "absl/strings/str_format.h"
#include "core/base/geometry.h"

namespace riskplan {
namespace {

// Rows [row_begin, row_end) of the layer.
void ComputeRows(const RiskModel& model, const RiskLayerOptions& options, const RiskLayer& layer,
                 int row_begin, int row_end, std::vector<double>* risk) {
  const RiskMap& map = model.map();
  const int heading_bins = model.table().heading_bins();
  const bool max_over_headings = std::isnan(options.heading_rad);
  for (int r = row_begin; r < row_end; ++r) {
    const double y = layer.centre_y(r);
    for (int c = 0; c < layer.nx; ++c) {
      const double x = layer.centre_x(c);
      // The terrain of the cell the model itself reads (spec step 1), so that
      // h is height_agl_m even where a centre falls on a cell corner (even
      // strides).
      int i = 0;
      int j = 0;
      double m = std::nan("");
      if (map.CellOf(x, y, &i, &j)) {
        const double z = static_cast<double>(map.terrain(i, j)) + options.height_agl_m;
        if (max_over_headings) {
          m = -std::numeric_limits<double>::infinity();
          for (int k = 0; k < heading_bins; ++k) {
            const ConfigurationRisk cr = model.Evaluate(Pose{x, y, z, k * kTwoPi / heading_bins});
            if (!cr.defined) {
              m = std::nan("");
              break;
            }
            m = std::max(m, cr.risk);
          }
        } else {
          const ConfigurationRisk cr = model.Evaluate(Pose{x, y, z, options.heading_rad});
          if (cr.defined) m = cr.risk;
        }
      }
      (*risk)[static_cast<size_t>(r) * layer.nx + c] = m;
    }
  }
}

}  // namespace

absl::StatusOr<LayerShape> LayerCells(const RiskMap& map, const RiskLayerOptions& options) {
  if (!(options.height_agl_m > 0.0) || !std::isfinite(options.height_agl_m)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "risk layer: height above ground %g m must be finite and > 0", options.height_agl_m));
  }
  if (std::isinf(options.heading_rad)) {
    return absl::InvalidArgumentError(
        "risk layer: heading must be finite (or NaN for the maximum)");
  }
  if (options.threads < 1 || options.threads > 256 || options.stride < 1) {
    return absl::InvalidArgumentError(
        absl::StrFormat("risk layer: threads (%d) must be in [1, 256] and stride (%d) >= 1",
                        options.threads, options.stride));
  }
  const int64_t i0 = options.first_column, j0 = options.first_row;
  const int64_t columns = options.columns == 0 ? map.nx() - i0 : options.columns;
  const int64_t rows = options.rows == 0 ? map.ny() - j0 : options.rows;
  if (i0 < 0 || j0 < 0 || columns < 1 || rows < 1 || i0 + columns > map.nx() ||
      j0 + rows > map.ny()) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "risk layer: the window of columns [%d, %d) and rows [%d, %d) is not inside the map of "
        "%d x %d cells",
        i0, i0 + columns, j0, j0 + rows, map.nx(), map.ny()));
  }
  if (options.stride > std::min(columns, rows)) {
    if (columns == map.nx() && rows == map.ny()) {
      return absl::InvalidArgumentError(
          absl::StrFormat("risk layer: stride %d is larger than the map of %d x %d cells",
                          options.stride, map.nx(), map.ny()));
    }
    return absl::InvalidArgumentError(
        absl::StrFormat("risk layer: stride %d is larger than the window of %d x %d cells",
                        options.stride, columns, rows));
  }
  // Whole blocks only (see risk_layer.h): a partial block would be a cell
  // reaching past the window, or one smaller than the raster says.
  return LayerShape{static_cast<int>(columns / options.stride),
                    static_cast<int>(rows / options.stride)};
}

absl::StatusOr<RiskLayer> ComputeRiskLayer(const RiskModel& model,
                                           const RiskLayerOptions& options) {
  const RiskMap& map = model.map();
  absl::StatusOr<LayerShape> shape = LayerCells(map, options);
  if (!shape.ok()) return shape.status();
  RiskLayer layer;
  layer.nx = shape->nx;
  layer.ny = shape->ny;
  layer.x0 = map.x0() + options.first_column * map.res();
  layer.y0 = map.y0() + options.first_row * map.res();
  layer.res_m = map.res() * options.stride;
  layer.risk.assign(static_cast<size_t>(layer.nx) * layer.ny, 0.0);
  // Interleaved bands of rows keep the threads' loads even (the centre of a
  // city costs the same as its edge, but hills change the kernel sizes).
  const int band = 8;
  std::atomic<bool> stopped{false};
  std::vector<std::thread> workers;
  for (int t = 0; t < options.threads; ++t) {
    workers.emplace_back([&, t] {
      for (int start = t * band; start < layer.ny; start += options.threads * band) {
        for (int r = start; r < std::min(layer.ny, start + band); ++r) {
          // Polled every row: a row of a wide layer at every heading bin is
          // the longest stretch of work without a check.
          if (options.stop.Reached()) {
            stopped.store(true);
            return;
          }
          ComputeRows(model, options, layer, r, r + 1, &layer.risk);
        }
      }
    });
  }
  for (std::thread& w : workers) w.join();
  if (stopped.load()) {
    return absl::CancelledError("risk layer: stopped before every row was computed");
  }
  const int per_cell = std::isnan(options.heading_rad) ? model.table().heading_bins() : 1;
  layer.evaluations = static_cast<int64_t>(layer.nx) * layer.ny * per_cell;
  return layer;
}

}  // namespace riskplan
