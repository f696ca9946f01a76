// Prometheus view of the accelerator engine: the riskplan_accel_* families
// of accel/engine_metrics.h, read from RiskEngine::Stats() at every scrape.
#ifndef RISKPLAN_SERVER_OBSERVABILITY_ACCEL_METRICS_H_
#define RISKPLAN_SERVER_OBSERVABILITY_ACCEL_METRICS_H_

#include <vector>

#include "accel/risk_engine.h"
#include "prometheus/collectable.h"
#include "prometheus/metric_family.h"

namespace riskplan::server {

class AccelMetrics final : public prometheus::Collectable {
 public:
  // `engine` must outlive every scrape (the server stops serving metrics
  // before it destroys the engine).
  explicit AccelMetrics(const accel::RiskEngine* engine) : engine_(engine) {}
  std::vector<prometheus::MetricFamily> Collect() const override;

 private:
  const accel::RiskEngine* engine_;
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_OBSERVABILITY_ACCEL_METRICS_H_
