#include "core/risk_layer.h"

#include <algorithm>
#include <cmath>
#include <thread>

#include "absl/strings/str_format.h"
#include "core/geometry.h"

namespace riskplan {
namespace {

// Rows [row_begin, row_end) of the layer.
void ComputeRows(const RiskModel& model, const RiskLayerOptions& options, const RiskLayer& layer,
                 int row_begin, int row_end, std::vector<double>* risk) {
  const RiskMap& map = model.map();
  const int heading_bins = model.table().heading_bins();
  for (int r = row_begin; r < row_end; ++r) {
    const int j = r * options.stride;
    for (int c = 0; c < layer.nx; ++c) {
      const int i = c * options.stride;
      const double x = map.x0() + (i + 0.5) * map.res();
      const double y = map.y0() + (j + 0.5) * map.res();
      const double z = static_cast<double>(map.terrain(i, j)) + options.height_agl_m;
      double m = 0.0;
      if (std::isnan(options.heading_rad)) {
        for (int k = 0; k < heading_bins; ++k) {
          m = std::max(m, model.Evaluate(Pose{x, y, z, k * kTwoPi / heading_bins}).risk);
        }
      } else {
        const ConfigurationRisk cr = model.Evaluate(Pose{x, y, z, options.heading_rad});
        m = cr.defined ? cr.risk : std::nan("");
      }
      (*risk)[static_cast<size_t>(r) * layer.nx + c] = m;
    }
  }
}

}  // namespace

absl::StatusOr<RiskLayer> ComputeRiskLayer(const RiskModel& model,
                                           const RiskLayerOptions& options) {
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
  const RiskMap& map = model.map();
  RiskLayer layer;
  layer.nx = (map.nx() + options.stride - 1) / options.stride;
  layer.ny = (map.ny() + options.stride - 1) / options.stride;
  layer.x0 = map.x0();
  layer.y0 = map.y0();
  layer.res_m = map.res() * options.stride;
  layer.risk.assign(static_cast<size_t>(layer.nx) * layer.ny, 0.0);
  // Interleaved bands of rows keep the threads' loads even (the centre of a
  // city costs the same as its edge, but hills change the kernel sizes).
  const int band = 8;
  std::vector<std::thread> workers;
  for (int t = 0; t < options.threads; ++t) {
    workers.emplace_back([&, t] {
      for (int start = t * band; start < layer.ny; start += options.threads * band) {
        ComputeRows(model, options, layer, start, std::min(layer.ny, start + band), &layer.risk);
      }
    });
  }
  for (std::thread& w : workers) w.join();
  const int per_cell = std::isnan(options.heading_rad) ? model.table().heading_bins() : 1;
  layer.evaluations = static_cast<int64_t>(layer.nx) * layer.ny * per_cell;
  return layer;
}

}  // namespace riskplan
