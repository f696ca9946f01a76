#include "server/models/feasibility_cache.h"

#include <utility>

#include "core/base/check.h"

namespace riskplan::server {

// Every option that changes what the checker computes, and the model by
// address (the entry keeps the model alive, so the address cannot be reused
// by another model while the entry exists).
FeasibilityCache::Key FeasibilityCache::KeyOf(const RiskModel* model,
                                              const TwoTierOptions& options) {
  return Key{model, static_cast<int>(options.rule), options.detailed_segments, options.block_cells,
             static_cast<int>(options.traversal)};
}

std::shared_ptr<const SharedFeasibility> FeasibilityCache::Get(
    std::shared_ptr<const RiskModel> model, const TwoTierOptions& options) {
  RISKPLAN_DCHECK(model != nullptr);
  RISKPLAN_DCHECK(CheckTwoTierOptions(options).ok());
  const Key key = KeyOf(model.get(), options);
  // Built without the lock (20 to 40 ms): hits on other checkers do not wait
  // for it. The build cannot fail, so neither can this.
  return *cache_.GetOrBuild(
      key, [&]() -> absl::StatusOr<BoundedCache<Key, SharedFeasibility>::Built> {
        auto built = std::make_shared<const SharedFeasibility>(std::move(model), options);
        return BoundedCache<Key, SharedFeasibility>::Built{built, built->checker.MemoryBytes()};
      });
}

FeasibilityCache::Stats FeasibilityCache::stats() const {
  const CacheStats s = cache_.stats();
  return Stats{.hits = s.hits,
               .builds = s.misses,
               .evictions = s.evictions,
               .cached = s.entries,
               .bytes = s.bytes};
}

}  // namespace riskplan::server
