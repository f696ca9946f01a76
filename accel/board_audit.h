// Spot checks of a board's EWMM sums against the CPU's exact ones.
//
// A frame can be valid, its scales right and its sums plausible, and still
// carry wrong numbers (a broken lane, a stale weight slot, a board that
// answers for the wrong map). FpgaWorker therefore recomputes a few sites of
// every EVAL reply on the CPU and refuses the reply when a board sum lies
// outside the number format's documented error bound (docs/accel.md), which
// a correct datapath never exceeds.
#ifndef RISKPLAN_ACCEL_BOARD_AUDIT_H_
#define RISKPLAN_ACCEL_BOARD_AUDIT_H_

#include "absl/status/status.h"
#include "accel/fixed_point.h"
#include "core/risk/risk_model.h"

namespace riskplan::accel {

// How a board quantises one map: its number format and the two layer
// exponents (LayerExponent of the largest density, and of 10 for shelter).
struct BoardScales {
  NumberFormat format;
  int density_exponent = 0;
  int shelter_exponent = 0;
};

// OK when `board_impact` and `board_shelter` (the board's sums for `site`,
// converted to double) are each within FixedPointSumBound of the exact sums
// RiskModel::Ewmm gives (window values as the spec reads them: density 0
// and shelter 10 outside the map), with 1e-12 relative slack for the two
// double roundings. DataLoss naming the site, both values and the bound
// otherwise.
absl::Status AuditBoardSums(const RiskModel& model, const KernelSite& site,
                            const BoardScales& scales, double board_impact, double board_shelter);

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_BOARD_AUDIT_H_
