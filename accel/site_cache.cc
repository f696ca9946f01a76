#include "accel/site_cache.h"

#include <algorithm>
#include <bit>

#include "core/base/check.h"
#include "core/base/hash_mix.h"

namespace riskplan::accel {

SiteCache::SiteCache(size_t budget_bytes, uint32_t max_tags)
    : max_tags_(std::min(max_tags, kMaxTag)) {
  if (budget_bytes < sizeof(Slot)) return;
  const size_t entries = std::bit_floor(budget_bytes / sizeof(Slot));
  slots_ = std::vector<Slot>(entries);
  mask_ = entries - 1;
}

SiteCache::Session SiteCache::Begin(const RiskModel& model, uint32_t variant) {
  if (slots_.empty()) return Session{};
  const double alpha = model.params().alpha_j;
  const double beta = model.params().beta_j;
  absl::MutexLock lock(&mu_);
  for (auto it = models_.begin(); it != models_.end();) {
    if (it->map.expired() || it->table.expired()) {
      // Its entries stay in the table but can never match again: the tag is
      // not handed out until the table is cleared.
      it = models_.erase(it);
      continue;
    }
    if (it->map.lock() == model.map_ptr() && it->table.lock() == model.table_ptr() &&
        it->alpha_j == alpha && it->beta_j == beta && it->variant == variant) {
      return Session{it->tag, epoch_.load()};
    }
    ++it;
  }
  if (next_tag_ > max_tags_) {
    // Tags ran out: forget everything and start over. Concurrent readers may
    // miss while this runs, never see a wrong value (keys are cleared first).
    ClearAll();
    next_tag_ = 1;
    models_.clear();
  }
  models_.push_back(ModelId{model.map_ptr(), model.table_ptr(), alpha, beta, variant, next_tag_});
  return Session{next_tag_++, epoch_.load()};
}

uint64_t SiteCache::KeyOf(const Session& session, const KernelSite& s) {
  const uint64_t tag = session.tag;
  if (tag == 0) return 0;
  const int64_t i = int64_t{s.impact_i} + (1 << 15);
  const int64_t j = int64_t{s.impact_j} + (1 << 15);
  if (s.height_bin < 0 || s.height_bin >= (1 << 7) || s.heading_bin < 0 ||
      s.heading_bin >= (1 << 9) || i < 0 || i >= (1 << 16) || j < 0 || j >= (1 << 16)) {
    return 0;
  }
  return (uint64_t{1} << 63) | (tag << 48) | (uint64_t(s.height_bin) << 41) |
         (uint64_t(s.heading_bin) << 32) | (uint64_t(i) << 16) | uint64_t(j);
}

SiteCache::Slot& SiteCache::SlotOf(uint64_t key) const { return slots_[Mix64(key) & mask_]; }

void SiteCache::Prefetch(uint64_t key) const {
  if (key != 0) __builtin_prefetch(&SlotOf(key));
}

bool SiteCache::Lookup(const Session& session, uint64_t key, Values* values) const {
  RISKPLAN_DCHECK(key != 0);
  const Slot& slot = SlotOf(key);
  if (slot.key.load(std::memory_order_acquire) != key) return false;
  const uint64_t impact = slot.impact_bits.load(std::memory_order_relaxed);
  const uint64_t shelter = slot.shelter_bits.load(std::memory_order_relaxed);
  const uint64_t probability = slot.probability_bits.load(std::memory_order_relaxed);
  std::atomic_thread_fence(std::memory_order_acquire);
  if (slot.key.load(std::memory_order_relaxed) != key) return false;
  // Values read before a new epoch began belong to this session's model.
  if (epoch_.load() != session.epoch) return false;
  values->impact_factor = std::bit_cast<double>(impact);
  values->expected_shelter = std::bit_cast<double>(shelter);
  values->casualty_probability = std::bit_cast<double>(probability);
  return true;
}

void SiteCache::Insert(const Session& session, uint64_t key, const Values& values) {
  RISKPLAN_DCHECK(key != 0);
  Slot& slot = SlotOf(key);
  uint64_t old = slot.key.load(std::memory_order_relaxed);
  if (old == kBusy || old == key) return;
  if (!slot.key.compare_exchange_strong(old, kBusy)) return;
  // Checked after claiming the slot: ClearAll() moves to the new epoch before
  // it sweeps, and waits for claimed slots, so a stale insert is either
  // refused here or swept.
  if (epoch_.load() != session.epoch) {
    slot.key.store(0);
    return;
  }
  std::atomic_thread_fence(std::memory_order_release);
  slot.impact_bits.store(std::bit_cast<uint64_t>(values.impact_factor), std::memory_order_relaxed);
  slot.shelter_bits.store(std::bit_cast<uint64_t>(values.expected_shelter),
                          std::memory_order_relaxed);
  slot.probability_bits.store(std::bit_cast<uint64_t>(values.casualty_probability),
                              std::memory_order_relaxed);
  slot.key.store(key, std::memory_order_release);
}

void SiteCache::ClearAll() {
  epoch_.fetch_add(1);
  for (Slot& slot : slots_) {
    uint64_t key = slot.key.load();
    // A writer holds a slot for a few stores only.
    while (key == kBusy || !slot.key.compare_exchange_weak(key, 0)) {
      if (key == kBusy) key = slot.key.load();
    }
  }
}

}  // namespace riskplan::accel
