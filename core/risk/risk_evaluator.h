// RiskEvaluator: the seam between the planners and whatever computes
// configuration risks. A planner hands over a *risk batch* (every sample of
// every candidate edge of one step) and gets M(q) for each; the accelerator
// layer (accel/) puts a worker pool behind this interface.
#ifndef RISKPLAN_CORE_RISK_RISK_EVALUATOR_H_
#define RISKPLAN_CORE_RISK_RISK_EVALUATOR_H_

#include <cstdint>
#include <span>
#include <vector>

#include "absl/status/status.h"
#include "core/base/check.h"
#include "core/base/geometry.h"
#include "core/risk/risk_model.h"

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
    RISKPLAN_DCHECK(out.size() == configs.size());
    for (size_t i = 0; i < configs.size(); ++i) out[i] = model.Evaluate(configs[i]);
    evaluated_ += configs.size();
    return absl::OkStatus();
  }
  uint64_t evaluated() const override { return evaluated_; }

 private:
  uint64_t evaluated_ = 0;
};

// Evaluates on the calling thread like DirectRiskEvaluator, and remembers the
// EWMM sums of the last kernel sites it saw in a direct-mapped table of
// 2^log2_entries entries (40 bytes each). M(q) depends on q only through its
// KernelSite, so a hit returns exactly what a fresh evaluation would: results
// are bit for bit those of DirectRiskEvaluator. Only valid for one RiskModel
// at a time (the table is cleared when another model is passed).
// Thread-compatible.
class CachingRiskEvaluator final : public RiskEvaluator {
 public:
  explicit CachingRiskEvaluator(int log2_entries = 18);

  absl::Status EvaluateBatch(const RiskModel& model, std::span<const Pose> configs,
                             std::span<ConfigurationRisk> out) override;
  uint64_t evaluated() const override { return evaluated_; }
  uint64_t hits() const { return hits_; }
  size_t MemoryBytes() const { return entries_.size() * sizeof(Entry); }

 private:
  struct Entry {
    uint64_t key = ~uint64_t{0};
    double impact_factor = 0.0;
    double expected_shelter = 0.0;
    double casualty_probability = 0.0;
    double risk = 0.0;
  };
  std::vector<Entry> entries_;
  uint64_t mask_ = 0;
  const RiskModel* model_ = nullptr;
  uint64_t evaluated_ = 0;
  uint64_t hits_ = 0;
};

}  // namespace riskplan

#endif  // RISKPLAN_CORE_RISK_RISK_EVALUATOR_H_
