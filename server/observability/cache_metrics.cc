#include "server/observability/cache_metrics.h"

#include <string>
#include <utility>

#include "core/planners/cost_to_go_field.h"

namespace riskplan::server {
namespace {

prometheus::MetricFamily Gauge(std::string name, std::string help) {
  prometheus::MetricFamily family;
  family.name = std::move(name);
  family.help = std::move(help);
  family.type = prometheus::MetricType::Gauge;
  return family;
}

prometheus::MetricFamily Counter(std::string name, std::string help, double value) {
  prometheus::MetricFamily family;
  family.name = std::move(name);
  family.help = std::move(help);
  family.type = prometheus::MetricType::Counter;
  prometheus::ClientMetric metric;
  metric.counter.value = value;
  family.metric.push_back(std::move(metric));
  return family;
}

void Add(prometheus::MetricFamily* family, double value,
         std::vector<prometheus::ClientMetric::Label> labels = {}) {
  prometheus::ClientMetric metric;
  metric.label = std::move(labels);
  metric.gauge.value = value;
  family->metric.push_back(std::move(metric));
}

}  // namespace

// Read from the caches' own stats at every scrape rather than kept in gauges
// updated on every change: the caches stay free of Prometheus, and reading
// them costs a lock and a walk over at most a few dozen entries.
std::vector<prometheus::MetricFamily> CacheMetrics::Collect() const {
  const RiskModelCache::Stats models = models_->stats();
  const FeasibilityCache::Stats checkers = checkers_->stats();
  std::vector<prometheus::MetricFamily> out;
  out.push_back(
      Gauge("riskplan_model_cache_bytes",
            "Impact tables and glide layers of risk models, by kind (default, overridden)"));
  Add(&out.back(), static_cast<double>(models.default_bytes), {{"kind", "default"}});
  Add(&out.back(), static_cast<double>(models.overridden_bytes), {{"kind", "overridden"}});
  out.push_back(Gauge("riskplan_model_cache_models", "Models for overridden parameters cached"));
  Add(&out.back(), static_cast<double>(models.overridden_cached));
  out.push_back(Gauge("riskplan_model_cache_limit_models",
                      "Most models for overridden parameters kept (--model_cache_size)"));
  Add(&out.back(), static_cast<double>(model_limit_));
  out.push_back(
      Gauge("riskplan_feasibility_cache_bytes", "Layers of the cached two-tier checkers"));
  Add(&out.back(), static_cast<double>(checkers.bytes));
  out.push_back(Gauge("riskplan_feasibility_cache_checkers", "Two-tier checkers cached"));
  Add(&out.back(), static_cast<double>(checkers.cached));
  out.push_back(Gauge("riskplan_feasibility_cache_limit_checkers",
                      "Most two-tier checkers kept (--feasibility_cache_size)"));
  Add(&out.back(), static_cast<double>(checkers_->capacity()));
  // Reported with the cache off too (zeros), so that dashboards need no
  // special case.
  const GoalTreeCache::Stats trees =
      goal_trees_ != nullptr ? goal_trees_->stats() : GoalTreeCache::Stats{};
  out.push_back(Counter("riskplan_goal_tree_cache_hits_total",
                        "PlanFleet shared groups that began from a cached goal tree",
                        static_cast<double>(trees.hits)));
  out.push_back(Counter("riskplan_goal_tree_cache_misses_total",
                        "PlanFleet shared groups that found no cached goal tree",
                        static_cast<double>(trees.misses)));
  out.push_back(Counter("riskplan_goal_tree_cache_evictions_total",
                        "Goal trees evicted to stay within --goal_tree_cache_mb",
                        static_cast<double>(trees.evictions)));
  out.push_back(Gauge("riskplan_goal_tree_cache_bytes", "Goal trees cached, estimated bytes"));
  Add(&out.back(), static_cast<double>(trees.bytes));
  out.push_back(Gauge("riskplan_goal_tree_cache_entries", "Goal trees cached"));
  Add(&out.back(), static_cast<double>(trees.entries));
  out.push_back(Gauge("riskplan_goal_tree_cache_limit_bytes",
                      "Most bytes of goal trees kept (--goal_tree_cache_mb; 0: off)"));
  Add(&out.back(), static_cast<double>(goal_trees_ != nullptr ? goal_trees_->max_bytes() : 0));
  // RISK_RRT_STAR's guide fields (`guide` = 1): the process's one cache.
  const GuideFieldCache& fields = GuideFieldCache::Default();
  const CacheStats guide = fields.stats();
  out.push_back(Counter("riskplan_guide_field_cache_hits_total",
                        "Guided plans (guide = 1) that found their goal's field cached",
                        static_cast<double>(guide.hits)));
  out.push_back(Counter("riskplan_guide_field_cache_misses_total",
                        "Guide fields built (or given up: a build that did not fit its plan's "
                        "budget is not kept)",
                        static_cast<double>(guide.misses)));
  out.push_back(Counter("riskplan_guide_field_cache_evictions_total",
                        "Guide fields evicted to stay within the cache's bounds",
                        static_cast<double>(guide.evictions)));
  out.push_back(Gauge("riskplan_guide_field_cache_bytes", "Guide fields cached, bytes"));
  Add(&out.back(), static_cast<double>(guide.bytes));
  out.push_back(Gauge("riskplan_guide_field_cache_entries", "Guide fields cached"));
  Add(&out.back(), static_cast<double>(guide.entries));
  out.push_back(Gauge("riskplan_guide_field_cache_limit_bytes", "Most bytes of guide fields kept"));
  Add(&out.back(), static_cast<double>(fields.limits().max_bytes));
  return out;
}

}  // namespace riskplan::server
