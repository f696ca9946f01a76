#include "server/plan/plan_evaluator.h"

#include "accel/kernel_evaluator.h"

namespace riskplan::server {

std::unique_ptr<RiskEvaluator> NewPlanEvaluator(accel::RiskEngine* engine,
                                                const PlanOptions& options, StopCondition stop) {
  if (engine != nullptr) return engine->NewEvaluator(stop);
  const auto cache = options.params.find("risk_cache_log2");
  if (cache != options.params.end() && cache->second > 0) return nullptr;
  return std::make_unique<accel::KernelRiskEvaluator>();
}

}  // namespace riskplan::server
