// PreparedMap: a copy of a RiskMap's padded density and shelter layers (the
// same float32 values and layout as RiskMap::padded_density()), in memory
// backed by 2 MiB pages where the kernel grants them.
//
// Why: a kernel window has one row per map row; on a large map each row sits
// on its own 4 KiB page, and a random configuration's window touches some 40
// pages, which misses the TLB again and again. On 2 MiB pages the whole of
// demo-city's layers take twelve TLB entries. (Copies as double were tried
// too: they save the float-to-double conversion but double the memory
// traffic, and measured slower on both access patterns.)
//
// PreparedMapCache holds the prepared maps of the maps in use, bounded by a
// byte budget (a BoundedCache keyed by the map, core/base/bounded_cache.h). It
// is thread-safe; a PreparedMap is immutable once built and is shared
// read-only between threads.
#ifndef RISKPLAN_ACCEL_PREPARED_MAP_H_
#define RISKPLAN_ACCEL_PREPARED_MAP_H_

#include <cstddef>
#include <cstdint>
#include <memory>

#include "absl/functional/function_ref.h"
#include "core/base/bounded_cache.h"
#include "core/map/risk_map.h"

namespace riskplan::accel {

// Memory from mmap, rounded up to whole 2 MiB pages, aligned on 2 MiB and
// advised MADV_HUGEPAGE. Move-only; unmapped on destruction.
class HugePageBuffer {
 public:
  HugePageBuffer() = default;
  // Allocates at least `bytes` zero-filled bytes; empty (data() null) when
  // the memory cannot be had.
  explicit HugePageBuffer(size_t bytes);
  HugePageBuffer(HugePageBuffer&& other) noexcept;
  HugePageBuffer& operator=(HugePageBuffer&& other) noexcept;
  HugePageBuffer(const HugePageBuffer&) = delete;
  HugePageBuffer& operator=(const HugePageBuffer&) = delete;
  ~HugePageBuffer();

  void* data() const { return data_; }
  size_t size() const { return size_; }

 private:
  void* data_ = nullptr;
  size_t size_ = 0;
};

class PreparedMap {
 public:
  // Copies the padded layers of `map` (8 bytes per padded cell: 24 MB for
  // demo-city). Null when the memory cannot be had. Does not keep `map`
  // alive: PreparedMapCache pairs a PreparedMap with its map.
  static std::shared_ptr<const PreparedMap> Build(const RiskMap& map);

  // Same layout as RiskMap::padded_density() / padded_shelter().
  const float* density() const { return density_; }
  const float* shelter() const { return shelter_; }
  size_t MemoryBytes() const { return buffer_.size(); }

  // Bytes Build() takes for `map`.
  static size_t BytesFor(const RiskMap& map);

 private:
  PreparedMap() = default;

  HugePageBuffer buffer_;
  const float* density_ = nullptr;
  const float* shelter_ = nullptr;
};

class PreparedMapCache {
 public:
  // Holds at most `budget_bytes` of prepared maps (0: none; then Get() always
  // returns null and kernels read the map's own layers).
  explicit PreparedMapCache(size_t budget_bytes) : cache_({.max_bytes = budget_bytes}) {}

  // The prepared form of `map`, built on first use by the calling thread
  // (about 10 ms for demo-city; other callers for the same map wait). Null
  // when the map alone exceeds the budget or memory is short. The least
  // recently used maps are dropped to make room; a dropped map stays valid
  // for holders of its shared_ptr. Never keeps `map` itself alive.
  std::shared_ptr<const PreparedMap> Get(const std::shared_ptr<const RiskMap>& map);

  size_t MemoryBytes() const { return cache_.stats().bytes; }
  size_t budget_bytes() const { return cache_.limits().max_bytes; }

 private:
  // Keyed by the map's address, with the map as the entry's owner: the entry
  // goes stale when the map is freed, so a new map at the same address is
  // never taken for it.
  BoundedCache<const RiskMap*, PreparedMap> cache_;
};

// The accelerator caches' common step: the value of `key` in `cache`, built
// by `build` on a miss and charged its MemoryBytes(), with `owner` as the
// entry's owner. Null when `build` returns null (memory short): that is not
// cached, and the callers that waited for it get null too.
template <typename K, typename V>
std::shared_ptr<const V> GetOrBuildOwned(BoundedCache<K, V>& cache, const K& key,
                                         const std::shared_ptr<const void>& owner,
                                         absl::FunctionRef<std::shared_ptr<const V>()> build) {
  absl::StatusOr<std::shared_ptr<const V>> value = cache.GetOrBuild(
      key,
      [&]() -> absl::StatusOr<typename BoundedCache<K, V>::Built> {
        std::shared_ptr<const V> built = build();
        if (built == nullptr) return absl::ResourceExhaustedError("memory short");
        return typename BoundedCache<K, V>::Built{built, built->MemoryBytes()};
      },
      owner);
  return value.ok() ? *value : nullptr;
}

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_PREPARED_MAP_H_
