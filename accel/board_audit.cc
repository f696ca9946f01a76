#include "accel/board_audit.h"

#include <cmath>

#include "absl/strings/str_format.h"

namespace riskplan::accel {

absl::Status AuditBoardSums(const RiskModel& model, const KernelSite& site,
                            const BoardScales& scales, double board_impact, double board_shelter) {
  const ImpactKernel& kernel = model.table().kernel(site.height_bin, site.heading_bin);
  double impact = 0.0;
  double shelter = 0.0;
  model.Ewmm(kernel, site.impact_i, site.impact_j, &impact, &shelter);
  // The bound needs the window's plain value sums.
  const RiskMap& map = model.map();
  const int hw = kernel.half_width;
  double density_sum = 0.0;
  double shelter_sum = 0.0;
  for (int j = site.impact_j - hw; j <= site.impact_j + hw; ++j) {
    for (int i = site.impact_i - hw; i <= site.impact_i + hw; ++i) {
      const bool in = map.Contains(i, j);
      density_sum += in ? map.density(i, j) : 0.0;
      shelter_sum += in ? map.shelter(i, j) : 10.0;
    }
  }
  // The format's bound, plus 1e-12 relative slack for the two double
  // roundings (board_audit.h).
  const int cells = kernel.Side() * kernel.Side();
  const double impact_bound =
      FixedPointSumBound(scales.format, scales.density_exponent, density_sum, cells) +
      1e-12 * impact;
  const double shelter_bound =
      FixedPointSumBound(scales.format, scales.shelter_exponent, shelter_sum, cells) +
      1e-12 * shelter;
  // Negated comparisons: a NaN from the board fails too.
  if (!(std::abs(board_impact - impact) <= impact_bound) ||
      !(std::abs(board_shelter - shelter) <= shelter_bound)) {
    return absl::DataLossError(absl::StrFormat(
        "board sums for site (height bin %d, heading bin %d, cell %d, %d) are I = %.17g, "
        "S = %.17g; the CPU's are %.17g, %.17g, and %s allows at most %.3g, %.3g off",
        site.height_bin, site.heading_bin, site.impact_i, site.impact_j, board_impact,
        board_shelter, impact, shelter, scales.format.Name(), impact_bound, shelter_bound));
  }
  return absl::OkStatus();
}

}  // namespace riskplan::accel
