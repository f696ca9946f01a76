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
  {
    // A list searched linearly: it holds at most `capacity_` entries (8 by
    // default), and splice moves a hit to the front without reallocating.
    absl::MutexLock lock(&mu_);
    for (auto it = entries_.begin(); it != entries_.end(); ++it) {
      if (it->first != key) continue;
      entries_.splice(entries_.begin(), entries_, it);
      ++stats_.hits;
      return entries_.front().second;
    }
  }
  // Built without the lock (20 to 40 ms): hits on other checkers must not
  // wait for it. Two misses on one key may both build; see below.
  auto built = std::make_shared<const SharedFeasibility>(std::move(model), options);
  absl::MutexLock lock(&mu_);
  ++stats_.builds;
  for (auto it = entries_.begin(); it != entries_.end(); ++it) {
    // Built meanwhile by another request: its copy is the cached one, and
    // this one is dropped, so that every later request shares one checker.
    if (it->first == key) return it->second;
  }
  entries_.emplace_front(key, built);
  while (entries_.size() > capacity_) {
    entries_.pop_back();
    ++stats_.evictions;
  }
  return built;
}

FeasibilityCache::Stats FeasibilityCache::stats() const {
  absl::MutexLock lock(&mu_);
  Stats stats = stats_;
  stats.cached = entries_.size();
  for (const auto& [key, entry] : entries_) stats.bytes += entry->checker.MemoryBytes();
  return stats;
}

}  // namespace riskplan::server
