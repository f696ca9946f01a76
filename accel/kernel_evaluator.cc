#include "accel/kernel_evaluator.h"

#include "core/base/check.h"

namespace riskplan::accel {
namespace {

CpuKernelOptions ExactOptions(Isa isa) {
  CpuKernelOptions options;
  options.precision = KernelPrecision::kExact;
  options.isa = isa;
  return options;
}

}  // namespace

KernelRiskEvaluator::KernelRiskEvaluator(Isa isa)
    : kernel_(/*maps=*/nullptr, /*sites=*/nullptr, ExactOptions(isa), /*weights=*/nullptr) {}

absl::Status KernelRiskEvaluator::EvaluateBatch(const RiskModel& model,
                                                std::span<const Pose> configs,
                                                std::span<ConfigurationRisk> out) {
  RISKPLAN_DCHECK(out.size() == configs.size());
  kernel_.Evaluate(model, configs, out);
  evaluated_ += configs.size();
  return absl::OkStatus();
}

KernelRiskEvaluator& ThreadKernelEvaluator() {
  thread_local KernelRiskEvaluator evaluator;
  return evaluator;
}

}  // namespace riskplan::accel
