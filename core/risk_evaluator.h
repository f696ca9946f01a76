// RiskEvaluator: the seam between the planners and whatever computes
// configuration risks. A planner hands over a *risk batch* (every sample of
// every candidate edge of one step) and gets M(q) for each; the accelerator
// layer (accel/) puts a worker pool behind this interface.
#ifndef RISKPLAN_CORE_RISK_EVALUATOR_H_
#define RISKPLAN_CORE_RISK_EVALUATOR_H_

#include <cstdint>
#include <span>

#include "absl/status/status.h"
#include "core/geometry.h"
#include "core/risk_model.h"

namespace riskplan {

class RiskEvaluator {
 public:
  virtual ~RiskEvaluator() = default;

  // Sets out[i] to the configuration risk of configs[i] under `model`, for every
  // i, in order. REQUIRES: out.size() == configs.size(). An error means no
  // result of the batch may be used. Implementations say whether concurrent
  // calls are allowed.
  virtual absl::Status EvaluateBatch(const RiskModel& model, std::span<const Pose> configs,
                                     std::span<ConfigurationRisk> out) = 0;

  // Configurations evaluated so far (for statistics).
  virtual uint64_t evaluated() const = 0;
};

// Evaluates batches directly on the calling thread with RiskModel::Evaluate.
// Thread-compatible (the counter is not synchronised).
class DirectRiskEvaluator final : public RiskEvaluator {
 public:
  absl::Status EvaluateBatch(const RiskModel& model, std::span<const Pose> configs,
                             std::span<ConfigurationRisk> out) override {
    for (size_t i = 0; i < configs.size(); ++i) out[i] = model.Evaluate(configs[i]);
    evaluated_ += configs.size();
    return absl::OkStatus();
  }
  uint64_t evaluated() const override { return evaluated_; }

 private:
  uint64_t evaluated_ = 0;
};

}  // namespace riskplan

#endif  // RISKPLAN_CORE_RISK_EVALUATOR_H_
