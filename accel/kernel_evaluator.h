// KernelRiskEvaluator: accel's exact CpuRiskKernel behind the core's
// RiskEvaluator seam, on the calling thread, without a worker pool: what a
// caller with a batch in hand and no RiskEngine (riskplan-server without
// --cpu_workers or --fpga_shims evaluating an EvaluateRisk request) uses
// instead of DirectRiskEvaluator. Its results are RiskModel::Evaluate's bit
// for bit (CpuRiskKernel with KernelPrecision::kExact); it is 2-3x faster
// along trajectories (docs/benchmarks.md).
//
// It holds no cache: no SiteCache (every window is computed, so a repeated
// request costs what the first did), no PreparedMap and no aligned weights
// (the map's and the table's own arrays are read), so it adds no memory
// beyond the kernel's scratch buffers.
//
// Thread-compatible: one per thread (ThreadKernelEvaluator()).
#ifndef RISKPLAN_ACCEL_KERNEL_EVALUATOR_H_
#define RISKPLAN_ACCEL_KERNEL_EVALUATOR_H_

#include <cstdint>
#include <span>

#include "absl/status/status.h"
#include "accel/cpu_kernel.h"
#include "core/risk/risk_evaluator.h"

namespace riskplan::accel {

class KernelRiskEvaluator final : public RiskEvaluator {
 public:
  // `isa`: kAuto, the best the machine has (lower choices for tests).
  explicit KernelRiskEvaluator(Isa isa = Isa::kAuto);

  // out[i] = model.Evaluate(configs[i]), bit for bit. Never fails.
  absl::Status EvaluateBatch(const RiskModel& model, std::span<const Pose> configs,
                             std::span<ConfigurationRisk> out) override;
  uint64_t evaluated() const override { return evaluated_; }
  const CpuRiskKernel& kernel() const { return kernel_; }

 private:
  CpuRiskKernel kernel_;
  uint64_t evaluated_ = 0;
};

// The calling thread's KernelRiskEvaluator (created on first use, kept for
// the thread's life): its scratch buffers are reused from call to call.
KernelRiskEvaluator& ThreadKernelEvaluator();

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_KERNEL_EVALUATOR_H_
