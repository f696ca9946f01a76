// The loops and the finishing arithmetic of CpuRiskKernel's float32 path
// (CpuKernelOptions::precision = kFloat32), which the spec allows to differ
// from the exact definition by 1e-5 relative (docs/risk-model.md, "The
// float32 path", gives the error analysis; docs/accel.md the design).
//
// - EWMM: weights rounded to float32 (KernelWeights, kFloat32), the map's
//   float32 layers read as they are, products and sums by fused
//   multiply-add in float32 (16 lanes with AVX-512, 8 with AVX2), each lane's
//   float32 sum flushed into double every kFlushRows rows, lanes added in
//   double. Without AVX2+FMA, products and sums are in double (products of
//   two floats are exact in double), which is more accurate still.
// - Steps 5-7 of the spec: e = exp(3 ln(beta/E) / S~) with ln(beta/E)
//   precomputed per height bin, in place of pow(beta/E, 3/S~).
//
// Sites and bins come from the exact locating (CpuRiskKernel::LocateBatch),
// so the float32 path differs from the exact one in the sums and p_cas only.
#ifndef RISKPLAN_ACCEL_FLOAT_KERNEL_H_
#define RISKPLAN_ACCEL_FLOAT_KERNEL_H_

#include <cstdint>
#include <memory>
#include <vector>

#include "accel/cpu_kernel.h"
#include "core/risk/risk_model.h"

namespace riskplan::accel {

// Rows summed in float32 before the lanes are added into double: bounds
// the length of every float32 rounding chain (docs/risk-model.md).
inline constexpr int kFlushRows = 16;

// One window: its kernel's float32 weights (rows 64-byte aligned, stride
// KernelWeights::StrideFor(side, kFloat32)) and the window's first cell in
// each map layer.
struct FloatWindow {
  const float* weights;
  const float* density;
  const float* shelter;
};

// Computes the sums of `n` windows of `side` rows and columns:
// impact_factor[c] and expected_shelter[c] belong to windows[c]. Each window
// reads side rows of ceil(side / 8) * 8 cells.
using FloatEwmmFn = void (*)(const FloatWindow* windows, int side, int weight_stride,
                             int64_t map_stride, double* impact_factor, double* expected_shelter);

// The instruction set the float32 loops use for `isa` (AVX2 needs FMA too).
Isa FloatIsa(Isa isa);
// How many windows of `side` cells one loop call takes at most with `isa`
// (1, 2 or 4).
int FloatGroupMax(Isa isa, int side);
// The loop for `n` windows (1 <= n <= FloatGroupMax(isa, side); n == 3 is
// not offered, use 2) of `side` <= 64 cells; `shared` when every window uses
// windows[0].weights.
FloatEwmmFn FloatLoopFor(Isa isa, int n, int side, bool shared);

// Steps 5-7 of the spec from the sums, with exp of a per-bin logarithm for
// pow. Thread-compatible.
class FastRiskFinisher {
 public:
  // Prepares the per-kernel constants of `model` (per height bin and air-heading
  // bin: in wind each has its own energy and exposed area) unless they are
  // the current ones (a cheap check).
  void PrepareFor(const RiskModel& model);

  // REQUIRES: PrepareFor(model) of the model the site belongs to.
  ConfigurationRisk Finish(const KernelSite& site, double impact_factor,
                           double expected_shelter) const;
  // Only p_cas, for SiteCache entries.
  double CasualtyProbability(const KernelSite& site, double expected_shelter) const;

 private:
  struct Bin {
    double exposed_area_m2;
    double three_log_ratio;  // 3 ln(beta / E)
    bool harmful;            // E > beta
  };
  std::weak_ptr<const ImpactTable> table_;
  double alpha_j_ = 0.0;
  double beta_j_ = 0.0;
  double sqrt_alpha_over_beta_ = 0.0;
  int heading_bins_ = 0;
  std::vector<Bin> bins_;  // index (b - 1) * heading_bins_ + k
  const Bin& BinOf(const KernelSite& site) const {
    return bins_[static_cast<size_t>(site.height_bin - 1) * heading_bins_ + site.heading_bin];
  }
};

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_FLOAT_KERNEL_H_
