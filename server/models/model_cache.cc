#include "server/models/model_cache.h"

#include <utility>

#include "absl/strings/str_format.h"
#include "core/base/check.h"

namespace riskplan::server {

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
  return overridden_.Peek(map.name() + fingerprint);
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
  // Requests for a model being built wait for that build, not on the cache's
  // lock: the build runs without it (about 0.5 s with a glide layer), so
  // lookups of other models go on meanwhile. Failures are not cached: a
  // stopped build, or a table over the limit, which the next request with
  // these parameters is told about the same way (and costs no more than a
  // ballistic integration).
  return overridden_.GetOrBuild(map.name() + fingerprint, [&] { return Build(map, params); });
}

absl::StatusOr<BoundedCache<std::string, RiskModel>::Built> RiskModelCache::Build(
    const RiskMap& map, const ModelParams& params) {
  // Share the default model's impact table when the table parameters match
  // (only the flight band, sampling step or failure rate differ, say), and
  // its kernel weights when only the wind differs: RiskModel::Create then
  // makes the wind's table from it (ImpactTable::InWind: the offsets and
  // energies of its kernel headers, a few milliseconds).
  std::shared_ptr<const RiskModel> base = Default(map);
  std::shared_ptr<const ImpactTable> table;
  if (base != nullptr && SameKernelParams(base->params(), params) &&
      base->table().res_m() == map.res()) {
    table = base->table_ptr();
  }
  std::shared_ptr<const RiskMap> map_ptr = registry_.Find(map.name());
  if (map_ptr == nullptr) {
    return absl::NotFoundError(absl::StrFormat("map '%s' is not served", map.name()));
  }
  absl::StatusOr<std::shared_ptr<const RiskModel>> model =
      RiskModel::Create(map_ptr, params, table, limits_);
  if (!model.ok()) return model.status();
  return BoundedCache<std::string, RiskModel>::Built{*model, ChargedBytes(**model, table.get())};
}

size_t RiskModelCache::ChargedBytes(const RiskModel& model, const ImpactTable* shared) {
  // What the model holds beyond the default model's: nothing of the table
  // when it is that table, its kernel headers when it shares the weights (a
  // table in another wind), and its own glide layer if any.
  size_t bytes = model.MemoryBytes();
  if (shared == nullptr) return bytes;
  if (&model.table() == shared) return bytes - shared->MemoryBytes();
  return bytes - model.table().WeightBytes();
}

RiskModelCache::Stats RiskModelCache::stats() const {
  const CacheStats cached = overridden_.stats();
  Stats s{.hits = cached.hits,
          .builds = cached.misses,
          .evictions = cached.evictions,
          .overridden_cached = cached.entries,
          .overridden_bytes = cached.bytes};
  for (const auto& [name, model] : defaults_) s.default_bytes += model->MemoryBytes();
  return s;
}

}  // namespace riskplan::server
