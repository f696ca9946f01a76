// SiteCache: an exact, bounded cache of configuration risks by kernel site,
// shared by every CPU kernel of a RiskEngine.
//
// M(q) depends on q only through its kernel site (height bin, heading bin,
// impact cell) and the model, so a hit returns bit for bit what a fresh
// evaluation gives: the entry keeps I, S~ and p_cas, and M = A_exp * p_cas * I
// is recomputed with the same operations as RiskModel::FromSums.
//
// The table is direct-mapped (one entry per slot, 32 bytes, two per cache
// line) and lock-free: a reader checks the slot's key before and after
// reading the values (a seqlock), a writer claims the slot with a
// compare-and-swap and simply skips the insert when another writer holds it.
// A key packs a model tag (15 bits), the bins (7 + 9 bits) and the impact
// cell (16 + 16 bits); sites that do not fit (very large maps, unusual bin
// counts) bypass the cache. Models are told apart by their map, impact table,
// casualty-model energies and a variant (results computed differently).
// When the 32767 tags run out the table is cleared and tags start over in a
// new epoch; lookups and inserts made under an older epoch then miss or are
// dropped, so a reused tag never meets an entry of another model.
//
// Thread-safe. Memory: exactly capacity_bytes(), allocated at construction.
#ifndef RISKPLAN_ACCEL_SITE_CACHE_H_
#define RISKPLAN_ACCEL_SITE_CACHE_H_

#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "core/risk/risk_model.h"

namespace riskplan::accel {

class SiteCache {
 public:
  static constexpr uint32_t kMaxTag = (1u << 15) - 1;

  // A table of the largest power of two of entries within `budget_bytes`
  // (a budget below 32 bytes makes a disabled cache). `max_tags` (at most
  // 32767) is lowered only by tests.
  explicit SiteCache(size_t budget_bytes, uint32_t max_tags = kMaxTag);

  bool enabled() const { return !slots_.empty(); }
  size_t capacity_bytes() const { return slots_.size() * sizeof(Slot); }

  // What a batch needs to use the cache for one model: the model's tag
  // (0 when the cache is disabled: then every key is 0) and the epoch.
  struct Session {
    uint32_t tag = 0;
    uint64_t epoch = 0;
  };
  // Registers `model` on first use. `variant` tells apart results of the
  // same model computed differently (the CPU kernel's exact and float32
  // paths): they get different tags.
  Session Begin(const RiskModel& model, uint32_t variant = 0);

  // The key of a site, or 0 when it does not fit (or the cache is disabled).
  static uint64_t KeyOf(const Session& session, const KernelSite& site);

  // Brings the key's slot towards the CPU (call a few sites ahead).
  void Prefetch(uint64_t key) const;

  struct Values {
    double impact_factor;
    double expected_shelter;
    double casualty_probability;
  };
  // True, with the values, when the key is present. REQUIRES: key != 0.
  bool Lookup(const Session& session, uint64_t key, Values* values) const;
  // Stores the values of a key (may be skipped under contention).
  // REQUIRES: key != 0.
  void Insert(const Session& session, uint64_t key, const Values& values);

  // Statistics (relaxed counters, for metrics).
  // Epochs begun (the table was cleared this many times).
  uint64_t epoch() const { return epoch_.load(); }
  uint64_t hits() const { return hits_.load(std::memory_order_relaxed); }
  uint64_t misses() const { return misses_.load(std::memory_order_relaxed); }
  void CountLookups(uint64_t hits, uint64_t misses) {
    hits_.fetch_add(hits, std::memory_order_relaxed);
    misses_.fetch_add(misses, std::memory_order_relaxed);
  }

 private:
  struct alignas(32) Slot {
    std::atomic<uint64_t> key{0};
    std::atomic<uint64_t> impact_bits{0};
    std::atomic<uint64_t> shelter_bits{0};
    std::atomic<uint64_t> probability_bits{0};
  };
  struct ModelId {
    std::weak_ptr<const RiskMap> map;
    std::weak_ptr<const ImpactTable> table;
    double alpha_j;
    double beta_j;
    uint32_t variant;
    uint32_t tag;
  };

  static constexpr uint64_t kBusy = 1;  // a writer holds the slot (never a valid key)

  Slot& SlotOf(uint64_t key) const;
  // Starts a new epoch and empties every slot.
  void ClearAll() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  mutable std::vector<Slot> slots_;
  uint64_t mask_ = 0;
  const uint32_t max_tags_;
  std::atomic<uint64_t> epoch_{0};
  absl::Mutex mu_;
  std::vector<ModelId> models_ ABSL_GUARDED_BY(mu_);
  uint32_t next_tag_ ABSL_GUARDED_BY(mu_) = 1;
  std::atomic<uint64_t> hits_{0};
  std::atomic<uint64_t> misses_{0};
};

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_SITE_CACHE_H_
