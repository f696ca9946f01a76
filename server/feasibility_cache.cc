#include "server/feasibility_cache.h"

#include <utility>

namespace riskplan::server {

FeasibilityCache::Key FeasibilityCache::KeyOf(const RiskModel* model,
                                              const TwoTierOptions& options) {
  return Key{model, static_cast<int>(options.rule), options.detailed_segments, options.block_cells,
             static_cast<int>(options.traversal)};
}

std::shared_ptr<const SharedFeasibility> FeasibilityCache::Get(
    std::shared_ptr<const RiskModel> model, const TwoTierOptions& options) {
  const Key key = KeyOf(model.get(), options);
  {
    absl::MutexLock lock(&mu_);
    for (auto it = entries_.begin(); it != entries_.end(); ++it) {
      if (it->first != key) continue;
      entries_.splice(entries_.begin(), entries_, it);
      ++stats_.hits;
      return entries_.front().second;
    }
  }
  auto built = std::make_shared<const SharedFeasibility>(std::move(model), options);
  absl::MutexLock lock(&mu_);
  ++stats_.builds;
  for (auto it = entries_.begin(); it != entries_.end(); ++it) {
    if (it->first == key) return it->second;  // built meanwhile by another request
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
