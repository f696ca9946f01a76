// Full-map risk layers: the configuration risk M of every cell of a map, for
// users who want to see where flying is risky (riskplan-tool risk-layer).
#ifndef RISKPLAN_CORE_RISK_LAYER_H_
#define RISKPLAN_CORE_RISK_LAYER_H_

#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/risk_model.h"

namespace riskplan {

struct RiskLayerOptions {
  double height_agl_m = 100.0;  // the aircraft flies this high above each cell
  // Heading in radians; NaN: the maximum of M over all heading bins.
  double heading_rad = 0.0;
  int threads = 1;  // rows are split between this many threads
  // Every `stride`-th cell in each direction (1: every cell).
  int stride = 1;
};

struct RiskLayer {
  int nx = 0;  // columns of the layer (map columns / stride, rounded up)
  int ny = 0;
  double x0 = 0.0;
  double y0 = 0.0;
  double res_m = 0.0;  // cell side of the layer
  // M per cell (expected casualties given a failure there), row-major, row 0
  // south; NaN where M is undefined (never, for a positive height).
  std::vector<double> risk;
  int64_t evaluations = 0;  // configuration risks computed
};

// Computes M at the centre of every (stride-th) cell, at height_agl_m above
// that cell's terrain. Deterministic whatever the thread count.
absl::StatusOr<RiskLayer> ComputeRiskLayer(const RiskModel& model, const RiskLayerOptions& options);

}  // namespace riskplan

#endif  // RISKPLAN_CORE_RISK_LAYER_H_
