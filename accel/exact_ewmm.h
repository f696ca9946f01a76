// The exact EWMM loops of the CPU kernel (accel/cpu_kernel.h), one per
// instruction set, window group size and kernel width: the sums of spec
// section 3 step 4 bit for bit RiskModel::Ewmm's (the same lanes, added in the
// same order; docs/accel.md "CPU kernel" explains the order). The float32
// path's loops are in accel/float_kernel.h.
#ifndef RISKPLAN_ACCEL_EXACT_EWMM_H_
#define RISKPLAN_ACCEL_EXACT_EWMM_H_

#include <cstdint>

#include "accel/cpu_kernel.h"

namespace riskplan::accel {

// Widest kernel the vector loops are specialised for: a side of 64 cells
// (spec hw_max = 31 gives 63). Wider kernels take RiskModel::Ewmm.
inline constexpr int kMaxExactSide = 64;

// One window: the kernel's weights and the window's first cell in each layer.
struct ExactWindow {
  const double* weights;
  const float* density;
  const float* shelter;
};

using ExactEwmmFn = void (*)(const ExactWindow*, int rows, int weight_stride, int64_t map_stride,
                             double* impact_factor, double* expected_shelter);

#if defined(__x86_64__)
// The loop for a group of `n` (1, 2 or 4; 4 only with kAvx512) windows of
// `side` <= kMaxExactSide cells; `shared` when they all use the same kernel.
// REQUIRES: isa is kAvx2 or kAvx512 and the CPU has it.
ExactEwmmFn ExactLoopFor(Isa isa, int n, int side, bool shared);
#endif

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_EXACT_EWMM_H_
