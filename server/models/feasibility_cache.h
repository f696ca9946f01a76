// FeasibilityCache: the two-tier feasibility checkers (core/two_tier_
// feasibility.h) that EvaluateRisk requests ask for.
//
// A checker is built from one RiskModel (a map with its model parameters)
// and one set of options, in 20 to 40 ms on demo-city, and holds 8 bytes per
// map cell (4 for the TERRAIN_ONLY rule). The cache keeps the most recently
// used `capacity` checkers. Each entry keeps its model alive, so a model's
// address identifies it for as long as the entry exists, and a checker is
// never used after its model is freed (the entries may keep at most
// `capacity` models that RiskModelCache has already evicted).
//
// A BoundedCache (core/base/bounded_cache.h) bounded by the entry count.
// Thread-safe. Two requests that miss on the same key at once build the
// checker once: the second waits for the first's build (and counts a hit).
// The lock is never held while building.
#ifndef RISKPLAN_SERVER_MODELS_FEASIBILITY_CACHE_H_
#define RISKPLAN_SERVER_MODELS_FEASIBILITY_CACHE_H_

#include <cstddef>
#include <cstdint>
#include <memory>
#include <tuple>
#include <utility>

#include "core/base/bounded_cache.h"
#include "core/risk/risk_model.h"
#include "core/planners/two_tier_feasibility.h"

namespace riskplan::server {

// A checker and the model it reads. Immutable; share it freely.
struct SharedFeasibility {
  SharedFeasibility(std::shared_ptr<const RiskModel> m, const TwoTierOptions& options)
      : model(std::move(m)), checker(*model, options) {}

  const std::shared_ptr<const RiskModel> model;
  const TwoTierFeasibility checker;
};

class FeasibilityCache {
 public:
  // `capacity` >= 1 checkers are kept (0 is taken as 1).
  explicit FeasibilityCache(size_t capacity)
      : cache_({.max_entries = capacity == 0 ? 1 : capacity}) {}

  // The checker of `model` with `options`. Builds it on the calling thread
  // when it is not cached: call this from a worker pool, never from a gRPC
  // thread. REQUIRES: CheckTwoTierOptions(options).ok(), `model` not null.
  std::shared_ptr<const SharedFeasibility> Get(std::shared_ptr<const RiskModel> model,
                                               const TwoTierOptions& options);

  struct Stats {
    uint64_t hits = 0;
    uint64_t builds = 0;
    uint64_t evictions = 0;
    size_t cached = 0;
    size_t bytes = 0;  // layers of the cached checkers
  };
  Stats stats() const;
  size_t capacity() const { return cache_.limits().max_entries; }

 private:
  using Key = std::tuple<const RiskModel*, int, int, int, int>;
  static Key KeyOf(const RiskModel* model, const TwoTierOptions& options);

  BoundedCache<Key, SharedFeasibility> cache_;  // each entry charged its layers
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_MODELS_FEASIBILITY_CACHE_H_
