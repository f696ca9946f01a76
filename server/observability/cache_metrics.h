// Prometheus view of the server's own caches, read at every scrape:
//
//   riskplan_model_cache_bytes{kind}         gauge  kind: default (the maps' default models,
//                                                   kept for ever), overridden (the LRU of
//                                                   models for overridden parameters)
//   riskplan_model_cache_models              gauge  overridden models cached
//   riskplan_model_cache_limit_models        gauge  their bound (--model_cache_size)
//   riskplan_feasibility_cache_bytes         gauge  two-tier checkers' layers
//   riskplan_feasibility_cache_checkers      gauge  checkers cached
//   riskplan_feasibility_cache_limit_checkers gauge their bound (--feasibility_cache_size)
//   riskplan_goal_tree_cache_hits_total      counter PlanFleet shared groups that began from a
//                                                   cached goal tree
//   riskplan_goal_tree_cache_misses_total    counter ... that grew theirs from the goal (cache on)
//   riskplan_goal_tree_cache_evictions_total counter trees evicted to stay within the bound
//   riskplan_goal_tree_cache_bytes           gauge  trees cached (GoalTreeCache::TreeBytes)
//   riskplan_goal_tree_cache_entries         gauge  trees cached
//   riskplan_goal_tree_cache_limit_bytes     gauge  their bound (--goal_tree_cache_mb; 0: off)
//   riskplan_guide_field_cache_hits_total    counter guided plans (guide = 1) whose goal's field
//                                                   was cached (GuideFieldCache::Default())
//   riskplan_guide_field_cache_misses_total  counter fields built or given up
//   riskplan_guide_field_cache_evictions_total counter fields evicted to stay within the bounds
//   riskplan_guide_field_cache_bytes         gauge  fields cached (CostToGoField::MemoryBytes)
//   riskplan_guide_field_cache_entries       gauge  fields cached
//   riskplan_guide_field_cache_limit_bytes   gauge  their bound (256 MiB)
//
// The accelerator's caches are in accel/engine_metrics.h (riskplan_accel_cache_bytes).
#ifndef RISKPLAN_SERVER_OBSERVABILITY_CACHE_METRICS_H_
#define RISKPLAN_SERVER_OBSERVABILITY_CACHE_METRICS_H_

#include <memory>
#include <vector>

#include "prometheus/collectable.h"
#include "prometheus/metric_family.h"
#include "server/models/feasibility_cache.h"
#include "server/models/goal_tree_cache.h"
#include "server/models/model_cache.h"

namespace riskplan::server {

class CacheMetrics final : public prometheus::Collectable {
 public:
  // `models` and `goal_trees` (null: the cache is off, its metrics read 0)
  // must outlive every scrape; the checkers are kept alive.
  CacheMetrics(const RiskModelCache* models, size_t model_limit,
               std::shared_ptr<const FeasibilityCache> checkers,
               const GoalTreeCache* goal_trees = nullptr)
      : models_(models),
        model_limit_(model_limit),
        checkers_(std::move(checkers)),
        goal_trees_(goal_trees) {}
  std::vector<prometheus::MetricFamily> Collect() const override;

 private:
  const RiskModelCache* models_;
  size_t model_limit_;
  std::shared_ptr<const FeasibilityCache> checkers_;
  const GoalTreeCache* goal_trees_;
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_OBSERVABILITY_CACHE_METRICS_H_
