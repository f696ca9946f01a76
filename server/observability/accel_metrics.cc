#include "server/observability/accel_metrics.h"

#include <map>
#include <string>

#include "accel/engine_metrics.h"

namespace riskplan::server {

std::vector<prometheus::MetricFamily> AccelMetrics::Collect() const {
  // EngineMetrics gives a flat list of samples (accel knows nothing of
  // Prometheus); Prometheus wants one family per name holding every labelled
  // sample of it. Samples of one name form one family, in the order they
  // first appear, so the exposition is stable from scrape to scrape.
  std::vector<prometheus::MetricFamily> families;
  std::map<std::string, size_t> index;
  for (const accel::MetricSample& sample : accel::EngineMetrics(engine_->Stats())) {
    auto [it, inserted] = index.emplace(sample.name, families.size());
    if (inserted) {
      prometheus::MetricFamily family;
      family.name = sample.name;
      family.help = "riskplan accelerator engine (see accel/engine_metrics.h)";
      family.type = sample.type == accel::MetricSample::Type::kCounter
                        ? prometheus::MetricType::Counter
                        : prometheus::MetricType::Gauge;
      families.push_back(std::move(family));
    }
    prometheus::ClientMetric metric;
    for (const auto& [name, value] : sample.labels) metric.label.push_back({name, value});
    if (sample.type == accel::MetricSample::Type::kCounter) {
      metric.counter.value = sample.value;
    } else {
      metric.gauge.value = sample.value;
    }
    families[it->second].metric.push_back(std::move(metric));
  }
  return families;
}

}  // namespace riskplan::server
