// RiskModelCache: the RiskModel of each (map, ModelParams) a request asks for.
//
// Building a RiskModel costs an impact table (about 50 ms) and, when the glide
// parameters differ from the map's, a glide layer (about 0.5 s on an 8 km
// map). A model that differs from the default only in its wind (or in
// parameters that do not shape the kernels) borrows the default model's
// kernel weights (RiskModel::Create with the default table: ImpactTable::
// InWind) and is charged only what it holds beyond them: its kernel headers
// and its glide layer (the wind's, spec version 3 section 6). The default-parameter model of every map is built once at start-up
// and kept for ever; models for overridden parameters are kept in a bounded
// LRU. Models are immutable and shared: a plan keeps its model alive even
// after the cache evicts it.
//
// Thread-safe. Concurrent requests for the same missing model wait for one
// build instead of building it twice (the overridden models are a
// BoundedCache bounded by their count, core/base/bounded_cache.h).
#ifndef RISKPLAN_SERVER_MODELS_MODEL_CACHE_H_
#define RISKPLAN_SERVER_MODELS_MODEL_CACHE_H_

#include <cstdint>
#include <map>
#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "core/base/bounded_cache.h"
#include "core/base/cancellation.h"
#include "core/base/model_params.h"
#include "core/map/risk_map.h"
#include "core/risk/impact_table.h"
#include "core/risk/risk_model.h"
#include "server/models/map_registry.h"

namespace riskplan::server {

class RiskModelCache {
 public:
  // Builds the default model of every map in `registry` (the registry must
  // outlive the cache). `max_overridden` bounds the models kept for
  // non-default parameters (0: none are kept, each request builds its own).
  // Every model is built within `limits` (its stop condition is replaced by
  // the cache's own, see StopBuilds).
  static absl::StatusOr<std::unique_ptr<RiskModelCache>> Create(
      const MapRegistry& registry, size_t max_overridden, const ModelBuildLimits& limits = {});

  // The model of `map` (a map of the registry) with `params`. Builds it on
  // the calling thread when it is not cached: call this from a worker pool,
  // never from a gRPC thread. REQUIRES: ValidateModelParams(params).ok().
  // A build beyond the limits fails with ImpactTable::Build's error, and
  // one stopped by StopBuilds with Cancelled (neither is cached).
  absl::StatusOr<std::shared_ptr<const RiskModel>> Get(const RiskMap& map,
                                                       const ModelParams& params);

  // Stops every build in progress and every later one (Cancelled): the
  // server's drain, so that no thread is left building a model nobody will
  // read. Thread-safe.
  void StopBuilds() { stop_builds_.Cancel(); }

  // The model if it is ready now, else null. Never builds; cheap.
  std::shared_ptr<const RiskModel> Peek(const RiskMap& map, const ModelParams& params);

  // The default-parameter model of `map` (never null for a registry map).
  std::shared_ptr<const RiskModel> Default(const RiskMap& map) const;

  struct Stats {
    uint64_t hits = 0;
    uint64_t builds = 0;
    uint64_t evictions = 0;
    size_t overridden_cached = 0;
    // Impact tables and glide layers of the default models (kept for ever),
    // and what the cached overridden models hold beyond them.
    size_t default_bytes = 0;
    size_t overridden_bytes = 0;
  };
  Stats stats() const;

  // A string that is equal exactly when every parameter is equal, bit for bit.
  static std::string Fingerprint(const ModelParams& params);

  // The bytes a cached `model` is charged: MemoryBytes() less what it shares
  // with `shared` (the default model's table it was made from, or null):
  // the whole table when it is `shared` itself, else the kernel weights (a
  // table in another wind shares them).
  static size_t ChargedBytes(const RiskModel& model, const ImpactTable* shared);

 private:
  RiskModelCache(const MapRegistry& registry, size_t max_overridden, const ModelBuildLimits& limits)
      : registry_(registry), limits_(limits), overridden_({.max_entries = max_overridden}) {
    limits_.stop = StopCondition(&stop_builds_);
  }

  // Builds the model for `params` (not the defaults) on this thread.
  absl::StatusOr<BoundedCache<std::string, RiskModel>::Built> Build(const RiskMap& map,
                                                                    const ModelParams& params);

  const MapRegistry& registry_;
  CancellationToken stop_builds_;
  ModelBuildLimits limits_;  // stops on stop_builds_
  // Immutable after Create().
  std::map<std::string, std::shared_ptr<const RiskModel>, std::less<>> defaults_;
  std::string default_fingerprint_;

  // The overridden models, keyed by map name + Fingerprint(params); each
  // charged what it holds that the default model does not share. The
  // defaults are not in it: they are never evicted, and kept where a lookup
  // takes no lock.
  BoundedCache<std::string, RiskModel> overridden_;
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_MODELS_MODEL_CACHE_H_
