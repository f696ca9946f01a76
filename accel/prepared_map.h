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
// byte budget. It is thread-safe; a PreparedMap is immutable once built and is
// shared read-only between threads.
#ifndef RISKPLAN_ACCEL_PREPARED_MAP_H_
#define RISKPLAN_ACCEL_PREPARED_MAP_H_

#include <cstddef>
#include <cstdint>
#include <list>
#include <memory>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
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
  explicit PreparedMapCache(size_t budget_bytes) : budget_bytes_(budget_bytes) {}

  // The prepared form of `map`, built on first use by the calling thread
  // (about 10 ms for demo-city; other callers for the same map wait). Null
  // when the map alone exceeds the budget or memory is short. The least
  // recently used maps are dropped to make room; a dropped map stays valid
  // for holders of its shared_ptr. Never keeps `map` itself alive.
  std::shared_ptr<const PreparedMap> Get(const std::shared_ptr<const RiskMap>& map);

  size_t MemoryBytes() const;
  size_t budget_bytes() const { return budget_bytes_; }

 private:
  struct Entry {
    const RiskMap* key;
    // Not owning; also tells a freed map from a new one at the same address.
    std::weak_ptr<const RiskMap> owner;
    std::shared_ptr<const PreparedMap> prepared;
  };

  std::shared_ptr<const PreparedMap> Find(const std::shared_ptr<const RiskMap>& map)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  const size_t budget_bytes_;
  // Serialises builds so that a map is never built twice at once.
  absl::Mutex build_mu_ ABSL_ACQUIRED_BEFORE(mu_);
  mutable absl::Mutex mu_;
  std::list<Entry> entries_ ABSL_GUARDED_BY(mu_);  // most recently used first
  size_t bytes_ ABSL_GUARDED_BY(mu_) = 0;
};

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_PREPARED_MAP_H_
