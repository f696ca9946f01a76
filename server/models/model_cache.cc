#include "server/models/model_cache.h"

#include <algorithm>
#include <utility>

#include "absl/strings/str_format.h"
#include "absl/synchronization/notification.h"
#include "core/base/check.h"

namespace riskplan::server {

// One overridden model, shared by the cache and every request waiting for it:
// a waiter keeps its Entry even if the cache drops it (a failed build, or
// eviction), so it still reads the result.
struct RiskModelCache::Entry {
  absl::Notification built;
  absl::StatusOr<std::shared_ptr<const RiskModel>> model;  // valid once `built` is notified
  size_t bytes = 0;  // what the model holds that the default model does not share
};

absl::StatusOr<std::unique_ptr<RiskModelCache>> RiskModelCache::Create(
    const MapRegistry& registry, size_t max_overridden, const ModelBuildLimits& limits) {
  std::unique_ptr<RiskModelCache> cache(new RiskModelCache(registry, max_overridden, limits));
  // Built here, before the server listens: most requests use the defaults,
  // and they then never wait for a build or take the lock (defaults_ is never
  // written again); a map whose default model cannot be built stops start-up
  // instead of failing requests.
  const ModelParams defaults;
  cache->default_fingerprint_ = Fingerprint(defaults);
  for (const std::shared_ptr<const RiskMap>& map : registry.maps()) {
    absl::StatusOr<std::shared_ptr<const RiskModel>> model =
        RiskModel::Create(map, defaults, nullptr, cache->limits_);
    if (!model.ok()) {
      return absl::Status(model.status().code(),
                          absl::StrFormat("map '%s': building the default risk model: %s",
                                          map->name(), model.status().message()));
    }
    cache->defaults_.emplace(map->name(), *std::move(model));
  }
  return cache;
}

std::string RiskModelCache::Fingerprint(const ModelParams& params) {
  std::string fingerprint;
  for (std::string_view name : ModelParamNames()) {
    // %a is exact: equal fingerprints mean bit-equal parameters.
    absl::StrAppendFormat(&fingerprint, "|%a", *GetModelParam(params, std::string(name)));
  }
  return fingerprint;
}

std::shared_ptr<const RiskModel> RiskModelCache::Default(const RiskMap& map) const {
  auto it = defaults_.find(map.name());
  return it == defaults_.end() ? nullptr : it->second;
}

std::shared_ptr<const RiskModel> RiskModelCache::Peek(const RiskMap& map,
                                                      const ModelParams& params) {
  const std::string fingerprint = Fingerprint(params);
  if (fingerprint == default_fingerprint_) return Default(map);
  const std::string key = map.name() + fingerprint;
  absl::MutexLock lock(&mu_);
  auto it = entries_.find(key);
  if (it == entries_.end() || !it->second->built.HasBeenNotified() || !it->second->model.ok()) {
    return nullptr;
  }
  ++stats_.hits;
  TouchLocked(key);
  return *it->second->model;
}

absl::StatusOr<std::shared_ptr<const RiskModel>> RiskModelCache::Get(const RiskMap& map,
                                                                     const ModelParams& params) {
  RISKPLAN_DCHECK(ValidateModelParams(params).ok());
  const std::string fingerprint = Fingerprint(params);
  if (fingerprint == default_fingerprint_) {
    std::shared_ptr<const RiskModel> model = Default(map);
    if (model == nullptr) {
      return absl::NotFoundError(absl::StrFormat("map '%s' is not served", map.name()));
    }
    return model;
  }
  const std::string key = map.name() + fingerprint;
  std::shared_ptr<Entry> entry;
  bool build = false;
  {
    absl::MutexLock lock(&mu_);
    auto [it, inserted] = entries_.try_emplace(key);
    if (inserted) {
      it->second = std::make_shared<Entry>();
      build = true;
      ++stats_.builds;
    } else {
      ++stats_.hits;
      if (it->second->built.HasBeenNotified()) TouchLocked(key);
    }
    entry = it->second;
  }
  // Requests for this model wait on its entry, not on mu_: the build below
  // runs without the lock (about 0.5 s with a glide layer), so lookups of
  // other models go on meanwhile.
  if (!build) {
    entry->built.WaitForNotification();
    return entry->model;
  }

  // Share the default model's impact table when the table parameters match
  // (only the flight band, sampling step or failure rate differ, say).
  std::shared_ptr<const RiskModel> base = Default(map);
  std::shared_ptr<const ImpactTable> table;
  if (base != nullptr && SameImpactTableParams(base->params(), params)) table = base->table_ptr();
  std::shared_ptr<const RiskMap> map_ptr = registry_.Find(map.name());
  if (map_ptr == nullptr) {
    entry->model = absl::NotFoundError(absl::StrFormat("map '%s' is not served", map.name()));
  } else {
    entry->model = RiskModel::Create(map_ptr, params, table, limits_);
    if (entry->model.ok()) {
      entry->bytes = (*entry->model)->MemoryBytes() - (table != nullptr ? table->MemoryBytes() : 0);
    }
  }
  {
    // Notified under the lock together with the LRU update, so that a
    // lookup that finds the entry built also finds it in lru_ (TouchLocked).
    absl::MutexLock lock(&mu_);
    entry->built.Notify();
    if (!entry->model.ok() || max_overridden_ == 0) {
      // Failures are not cached: a stopped build, or a table over the
      // limit, which the next request with these parameters is told about
      // the same way (and costs no more than a ballistic integration).
      entries_.erase(key);
    } else {
      lru_.push_front(key);
      EvictLocked();
    }
  }
  return entry->model;
}

// Linear in the LRU's length, which is --model_cache_size (4 by default).
void RiskModelCache::TouchLocked(const std::string& key) {
  auto it = std::find(lru_.begin(), lru_.end(), key);
  if (it != lru_.end()) lru_.splice(lru_.begin(), lru_, it);
}

void RiskModelCache::EvictLocked() {
  while (lru_.size() > max_overridden_) {
    entries_.erase(lru_.back());
    lru_.pop_back();
    ++stats_.evictions;
  }
}

RiskModelCache::Stats RiskModelCache::stats() const {
  absl::MutexLock lock(&mu_);
  Stats s = stats_;
  s.overridden_cached = lru_.size();
  // Every key in lru_ has an entry: both change together under mu_.
  for (const std::string& key : lru_) s.overridden_bytes += entries_.at(key)->bytes;
  for (const auto& [name, model] : defaults_) s.default_bytes += model->MemoryBytes();
  return s;
}

}  // namespace riskplan::server
