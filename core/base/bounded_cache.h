// BoundedCache<K, V>: a thread-safe map from K to shared_ptr<const V>, bounded
// by bytes and by a number of entries, least recently used out first. The
// server's model, checker and goal-tree caches and the accelerator's blob,
// kernel-weight and prepared-map caches are all one of these with their own
// keys and rules around it.
//
// - Values are immutable and shared: an evicted value stays valid for whoever
//   holds its shared_ptr. Evicted values are released after the lock is
//   dropped, so that freeing a large one does not hold up other callers.
// - Each entry counts the bytes its caller says it holds (a value may share
//   memory with others that it should not be charged for).
// - Build once: GetOrBuild() on a missing key runs the build on the calling
//   thread, without the lock (lookups of other keys go on meanwhile); every
//   concurrent GetOrBuild() on that key waits for that build and gets its
//   value or its error. A failed build is not cached (the next call builds
//   again: a failure may be transient, like a stopped build or short memory)
//   but is reported to every caller that waited for it, so that one build
//   costs one attempt however many callers asked. A build that throws is a failed
//   build too: its waiters get an error, and the exception goes on to the
//   caller that built.
// - A value larger than the whole bound (or any value when max_entries is 0)
//   is returned but not kept, and evicts nothing.
// - Owned entries: an entry may name an owner (the object its value was
//   derived from, e.g. a map). The cache never keeps the owner alive; once it
//   is freed the entry is stale: lookups miss it, and every insertion first
//   drops the stale entries, before evicting live ones.
//
// Counts: a hit is a lookup answered by a cached value or by waiting for
// another caller's build; a miss is a Find() that found nothing or a
// GetOrBuild() that built. Evictions count entries dropped to make room
// (stale entries and values not kept are not evictions).
#ifndef RISKPLAN_CORE_BASE_BOUNDED_CACHE_H_
#define RISKPLAN_CORE_BASE_BOUNDED_CACHE_H_

#include <cstddef>
#include <cstdint>
#include <functional>
#include <iterator>
#include <limits>
#include <list>
#include <map>
#include <memory>
#include <utility>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/functional/function_ref.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"

namespace riskplan {

// A BoundedCache's counts (the same type for every key and value, so that a
// cache's owner can hand them on as they are).
struct CacheStats {
  uint64_t hits = 0;
  uint64_t misses = 0;
  uint64_t evictions = 0;
  size_t entries = 0;  // cached values (builds in progress not counted)
  size_t bytes = 0;    // their bytes
};

template <typename K, typename V, typename Compare = std::less<K>>
class BoundedCache {
 public:
  struct Limits {
    size_t max_bytes = std::numeric_limits<size_t>::max();
    size_t max_entries = std::numeric_limits<size_t>::max();
  };
  // What a build returns: the value and the bytes it is charged.
  struct Built {
    std::shared_ptr<const V> value;
    size_t bytes = 0;
  };
  using Stats = CacheStats;

  explicit BoundedCache(Limits limits) : limits_(limits) {}
  BoundedCache(const BoundedCache&) = delete;
  BoundedCache& operator=(const BoundedCache&) = delete;

  const Limits& limits() const { return limits_; }

  // The cached value of `key`, made the most recently used, or null (also
  // while it is being built). Counts a hit or a miss.
  std::shared_ptr<const V> Find(const K& key) { return Lookup(key, /*count_miss=*/true); }

  // As Find(), but a miss is not counted: a look that does not ask for the
  // value (it would build it elsewhere if needed).
  std::shared_ptr<const V> Peek(const K& key) { return Lookup(key, /*count_miss=*/false); }

  // The value of `key`: cached, or awaited from a build in progress, or built
  // now by `build` on this thread (which must return a non-null value or an
  // error). `owner`, when not null, makes the new entry stale once it is
  // freed (see above); the cache keeps only a weak_ptr to it.
  absl::StatusOr<std::shared_ptr<const V>> GetOrBuild(
      const K& key, absl::FunctionRef<absl::StatusOr<Built>()> build,
      const std::shared_ptr<const void>& owner = nullptr);

  // Caches `value` (not null) for `key`, the most recently used, unless
  // `keep_existing(cached value)` says the one cached is to stay (then
  // nothing changes, not even the order). Returns whether `value` was kept.
  // A key being built is left to its build.
  bool Put(const K& key, std::shared_ptr<const V> value, size_t bytes,
           absl::FunctionRef<bool(const V&)> keep_existing);

  Stats stats() const {
    absl::MutexLock lock(&mu_);
    Stats s = stats_;
    s.entries = lru_.size();
    s.bytes = bytes_;
    return s;
  }

 private:
  // A build in progress, shared by its builder and its waiters: a waiter
  // keeps it even after the entry is dropped (a failed build), and reads the
  // result from it.
  struct Pending {
    bool done = false;
    absl::StatusOr<std::shared_ptr<const V>> result;
  };
  struct Entry;
  // Ordered rather than hashed: the keys (strings, pairs, tuples of
  // pointers) then need only operator<, and the caches hold a few dozen
  // entries at most.
  using Map = std::map<K, Entry, Compare>;
  struct Entry {
    std::shared_ptr<Pending> pending;  // set while building, then null
    std::shared_ptr<const V> value;    // set once built
    size_t bytes = 0;
    bool owned = false;
    std::weak_ptr<const void> owner;
    typename std::list<typename Map::iterator>::iterator lru;  // when cached
  };
  using Dropped = std::vector<std::shared_ptr<const V>>;

  static bool Stale(const Entry& e) { return e.owned && e.owner.expired(); }

  std::shared_ptr<const V> Lookup(const K& key, bool count_miss);
  // The entry of `key`, cached or being built, or end(). A stale entry is
  // dropped (its value to `dropped`) and not returned.
  typename Map::iterator FindLocked(const K& key, Dropped* dropped)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Unlinks a cached entry; its value goes to `dropped`.
  void EraseLocked(typename Map::iterator it, Dropped* dropped) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Drops the stale entries, then the least recently used ones until `bytes`
  // more fit. False (nothing evicted) when `bytes` cannot fit at all.
  bool MakeRoomLocked(size_t bytes, Dropped* dropped) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  void LinkLocked(typename Map::iterator it, std::shared_ptr<const V> value, size_t bytes)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Ends a build that threw: its waiters get an error, and its entry goes.
  void Abandon(const K& key, Pending& pending) ABSL_LOCKS_EXCLUDED(mu_);

  const Limits limits_;
  mutable absl::Mutex mu_;
  absl::CondVar built_;  // signalled whenever a build ends
  Map entries_ ABSL_GUARDED_BY(mu_);
  std::list<typename Map::iterator> lru_ ABSL_GUARDED_BY(mu_);  // cached only; front: newest
  size_t bytes_ ABSL_GUARDED_BY(mu_) = 0;
  Stats stats_ ABSL_GUARDED_BY(mu_);
};

template <typename K, typename V, typename C>
std::shared_ptr<const V> BoundedCache<K, V, C>::Lookup(const K& key, bool count_miss) {
  Dropped dropped;  // released after the lock (declared before it)
  absl::MutexLock lock(&mu_);
  auto it = FindLocked(key, &dropped);
  if (it == entries_.end() || it->second.pending != nullptr) {
    if (count_miss) ++stats_.misses;
    return nullptr;
  }
  ++stats_.hits;
  lru_.splice(lru_.begin(), lru_, it->second.lru);
  return it->second.value;
}

template <typename K, typename V, typename C>
absl::StatusOr<std::shared_ptr<const V>> BoundedCache<K, V, C>::GetOrBuild(
    const K& key, absl::FunctionRef<absl::StatusOr<Built>()> build,
    const std::shared_ptr<const void>& owner) {
  Dropped dropped;
  std::shared_ptr<Pending> pending;
  {
    absl::MutexLock lock(&mu_);
    auto it = FindLocked(key, &dropped);
    if (it != entries_.end()) {
      ++stats_.hits;
      if (it->second.pending == nullptr) {
        lru_.splice(lru_.begin(), lru_, it->second.lru);
        return it->second.value;
      }
      // Built by another caller: wait for it on the condition variable, not
      // by holding mu_, so that other keys are served meanwhile.
      std::shared_ptr<Pending> other = it->second.pending;
      while (!other->done) built_.Wait(&mu_);
      return other->result;
    }
    ++stats_.misses;
    pending = std::make_shared<Pending>();
    Entry& entry = entries_[key];
    entry.pending = pending;
    entry.owned = owner != nullptr;
    entry.owner = owner;
  }

  absl::StatusOr<Built> built = absl::UnknownError("not built");
  try {
    built = build();
  } catch (...) {
    // The waiters must not wait for ever, nor the key stay pending: they get
    // an error and the entry goes, and the exception goes on to this caller
    // (the server turns bad_alloc into RESOURCE_EXHAUSTED).
    Abandon(key, *pending);
    throw;
  }

  absl::MutexLock lock(&mu_);
  auto it = entries_.find(key);  // still there: only its build removes it
  pending->done = true;
  if (!built.ok()) {
    pending->result = built.status();
    entries_.erase(it);
  } else {
    pending->result = built->value;
    it->second.pending = nullptr;
    if (MakeRoomLocked(built->bytes, &dropped)) {
      LinkLocked(it, built->value, built->bytes);
    } else {
      entries_.erase(it);
    }
  }
  built_.SignalAll();
  return pending->result;
}

template <typename K, typename V, typename C>
void BoundedCache<K, V, C>::Abandon(const K& key, Pending& pending) {
  absl::MutexLock lock(&mu_);
  pending.done = true;
  pending.result = absl::InternalError(
      "building this cache entry failed with an exception (the caller that built it got it); "
      "try again");
  entries_.erase(key);  // still there: only its build removes it
  built_.SignalAll();
}

template <typename K, typename V, typename C>
bool BoundedCache<K, V, C>::Put(const K& key, std::shared_ptr<const V> value, size_t bytes,
                                absl::FunctionRef<bool(const V&)> keep_existing) {
  Dropped dropped;
  absl::MutexLock lock(&mu_);
  // A value that cannot be kept leaves the cache as it was.
  if (bytes > limits_.max_bytes || limits_.max_entries == 0) return false;
  auto it = entries_.find(key);
  if (it != entries_.end()) {
    if (it->second.pending != nullptr) return false;
    if (!Stale(it->second) && keep_existing(*it->second.value)) return false;
    EraseLocked(it, &dropped);
  }
  MakeRoomLocked(bytes, &dropped);
  LinkLocked(entries_.try_emplace(key).first, std::move(value), bytes);
  return true;
}

template <typename K, typename V, typename C>
typename BoundedCache<K, V, C>::Map::iterator BoundedCache<K, V, C>::FindLocked(const K& key,
                                                                                Dropped* dropped) {
  auto it = entries_.find(key);
  if (it == entries_.end() || it->second.pending != nullptr || !Stale(it->second)) return it;
  EraseLocked(it, dropped);
  return entries_.end();
}

template <typename K, typename V, typename C>
void BoundedCache<K, V, C>::EraseLocked(typename Map::iterator it, Dropped* dropped) {
  bytes_ -= it->second.bytes;
  lru_.erase(it->second.lru);
  dropped->push_back(std::move(it->second.value));
  entries_.erase(it);
}

template <typename K, typename V, typename C>
bool BoundedCache<K, V, C>::MakeRoomLocked(size_t bytes, Dropped* dropped) {
  for (auto lru = lru_.begin(); lru != lru_.end();) {
    auto it = *lru++;
    if (Stale(it->second)) EraseLocked(it, dropped);
  }
  if (bytes > limits_.max_bytes || limits_.max_entries == 0) return false;
  while (!lru_.empty() &&
         (bytes_ + bytes > limits_.max_bytes || lru_.size() + 1 > limits_.max_entries)) {
    EraseLocked(lru_.back(), dropped);
    ++stats_.evictions;
  }
  return true;
}

template <typename K, typename V, typename C>
void BoundedCache<K, V, C>::LinkLocked(typename Map::iterator it, std::shared_ptr<const V> value,
                                       size_t bytes) {
  it->second.value = std::move(value);
  it->second.bytes = bytes;
  lru_.push_front(it);
  it->second.lru = lru_.begin();
  bytes_ += bytes;
}

}  // namespace riskplan

#endif  // RISKPLAN_CORE_BASE_BOUNDED_CACHE_H_
