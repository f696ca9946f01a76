#include "core/base/bounded_cache.h"

#include <atomic>
#include <chrono>
#include <memory>
#include <new>
#include <string>
#include <thread>
#include <vector>

#include "absl/synchronization/notification.h"
#include "core/base/hash_mix.h"
#include "gtest/gtest.h"

namespace riskplan {
namespace {

using Cache = BoundedCache<int, std::string>;

Cache::Built Value(std::string s, size_t bytes) {
  return Cache::Built{std::make_shared<const std::string>(std::move(s)), bytes};
}

// Builds `value` charged `bytes`, counting the builds.
auto Builder(std::atomic<int>* builds, const std::string& value, size_t bytes) {
  return [=]() -> absl::StatusOr<Cache::Built> {
    ++*builds;
    return Value(value, bytes);
  };
}

bool Never(const std::string&) { return false; }

void ExpectStats(const Cache& cache, uint64_t hits, uint64_t misses, uint64_t evictions,
                 size_t entries, size_t bytes) {
  const Cache::Stats s = cache.stats();
  EXPECT_EQ(s.hits, hits);
  EXPECT_EQ(s.misses, misses);
  EXPECT_EQ(s.evictions, evictions);
  EXPECT_EQ(s.entries, entries);
  EXPECT_EQ(s.bytes, bytes);
}

TEST(BoundedCacheTest, BuildsOnceThenHits) {
  Cache cache({});
  std::atomic<int> builds = 0;
  absl::StatusOr<std::shared_ptr<const std::string>> a =
      cache.GetOrBuild(1, Builder(&builds, "a", 10));
  ASSERT_TRUE(a.ok());
  absl::StatusOr<std::shared_ptr<const std::string>> again =
      cache.GetOrBuild(1, Builder(&builds, "other", 10));
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(*again, *a);  // the same shared value
  EXPECT_EQ(builds, 1);
  EXPECT_EQ(cache.Find(1), *a);
  EXPECT_EQ(cache.Find(2), nullptr);
  EXPECT_EQ(cache.Peek(3), nullptr);  // no miss counted
  // Misses: the build and Find(2).
  ExpectStats(cache, /*hits=*/2, /*misses=*/2, /*evictions=*/0, /*entries=*/1, /*bytes=*/10);
}

TEST(BoundedCacheTest, ByteBudgetEvictsLeastRecentlyUsedFirst) {
  Cache cache({.max_bytes = 30});
  ASSERT_TRUE(cache.Put(1, Value("1", 10).value, 10, Never));
  ASSERT_TRUE(cache.Put(2, Value("2", 10).value, 10, Never));
  ASSERT_TRUE(cache.Put(3, Value("3", 10).value, 10, Never));
  EXPECT_EQ(cache.stats().bytes, 30u);                         // at the bound: nothing evicted
  ASSERT_NE(cache.Find(1), nullptr);                           // 2 is now the least recently used
  ASSERT_TRUE(cache.Put(4, Value("4", 15).value, 15, Never));  // 2 and 3 go
  EXPECT_EQ(cache.Find(2), nullptr);
  EXPECT_EQ(cache.Find(3), nullptr);
  EXPECT_NE(cache.Find(1), nullptr);
  EXPECT_NE(cache.Find(4), nullptr);
  ExpectStats(cache, /*hits=*/3, /*misses=*/2, /*evictions=*/2, /*entries=*/2, /*bytes=*/25);
}

TEST(BoundedCacheTest, ValueLargerThanTheBudgetIsReturnedButNotKept) {
  Cache cache({.max_bytes = 30});
  ASSERT_TRUE(cache.Put(1, Value("1", 10).value, 10, Never));
  std::atomic<int> builds = 0;
  absl::StatusOr<std::shared_ptr<const std::string>> big =
      cache.GetOrBuild(2, Builder(&builds, "big", 31));
  ASSERT_TRUE(big.ok());
  EXPECT_EQ(**big, "big");
  EXPECT_FALSE(cache.Put(3, Value("3", 31).value, 31, Never));
  // 1 stays: nothing was evicted for them.
  ExpectStats(cache, /*hits=*/0, /*misses=*/1, /*evictions=*/0, /*entries=*/1, /*bytes=*/10);
}

TEST(BoundedCacheTest, EntryLimit) {
  Cache cache({.max_entries = 2});
  std::atomic<int> builds = 0;
  for (int key : {1, 2, 1, 3}) ASSERT_TRUE(cache.GetOrBuild(key, Builder(&builds, "v", 1)).ok());
  EXPECT_EQ(builds, 3);
  EXPECT_EQ(cache.Find(2), nullptr);  // 1 was used after 2
  EXPECT_NE(cache.Find(1), nullptr);
  EXPECT_EQ(cache.stats().evictions, 1u);

  Cache none({.max_entries = 0});
  ASSERT_TRUE(none.GetOrBuild(1, Builder(&builds, "v", 1)).ok());
  EXPECT_EQ(none.stats().entries, 0u);
}

TEST(BoundedCacheTest, PutKeepsTheExistingValueWhenAsked) {
  Cache cache({});
  auto longer = std::make_shared<const std::string>("longer");
  ASSERT_TRUE(cache.Put(1, longer, 6, Never));
  const auto keep_longer = [](size_t size) {
    return [size](const std::string& cached) { return cached.size() >= size; };
  };
  EXPECT_FALSE(cache.Put(1, std::make_shared<const std::string>("short"), 5, keep_longer(5)));
  EXPECT_EQ(cache.Find(1), longer);
  auto longest = std::make_shared<const std::string>("longest");
  EXPECT_TRUE(cache.Put(1, longest, 7, keep_longer(7)));
  EXPECT_EQ(cache.Find(1), longest);
  EXPECT_EQ(cache.stats().entries, 1u);
  EXPECT_EQ(cache.stats().bytes, 7u);
}

// Runs GetOrBuild(7) on `threads` threads at once with a build that waits
// until every thread has had time to reach the cache, then returns
// `result`. Returns what each thread got and counts the builds.
std::vector<absl::StatusOr<std::shared_ptr<const std::string>>> Race(
    Cache* cache, int threads, const absl::StatusOr<Cache::Built>& result,
    std::atomic<int>* builds) {
  absl::Notification release;
  std::atomic<int> started = 0;
  std::vector<absl::StatusOr<std::shared_ptr<const std::string>>> got(threads);
  std::vector<std::thread> running;
  for (int t = 0; t < threads; ++t) {
    running.emplace_back([&, t] {
      ++started;
      got[t] = cache->GetOrBuild(7, [&] {
        ++*builds;
        release.WaitForNotification();  // the others arrive meanwhile
        return result;
      });
    });
  }
  while (started < threads) std::this_thread::yield();
  // Every thread has started; give them time to reach the cache (a late one
  // finds the value cached, or builds again after a failure: the tests allow
  // for both).
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  release.Notify();
  for (std::thread& t : running) t.join();
  return got;
}

// N threads miss on one key at once: one builds, the others wait for it and
// share its value.
TEST(BoundedCacheTest, ConcurrentMissesBuildOnce) {
  constexpr int kThreads = 8;
  Cache cache({});
  std::atomic<int> builds = 0;
  const auto got = Race(&cache, kThreads, Value("seven", 5), &builds);
  EXPECT_EQ(builds, 1);
  for (int t = 0; t < kThreads; ++t) {
    ASSERT_TRUE(got[t].ok());
    EXPECT_EQ(*got[t], *got[0]);
  }
  ExpectStats(cache, /*hits=*/kThreads - 1, /*misses=*/1, /*evictions=*/0, /*entries=*/1,
              /*bytes=*/5);
}

// A failed build is reported to every caller that waited for it (one attempt
// however many asked), and not cached: the next call builds again, since a
// failure may be transient (a stopped build, memory short).
TEST(BoundedCacheTest, FailedBuildReachesEveryWaiterAndIsNotCached) {
  constexpr int kThreads = 6;
  Cache cache({});
  std::atomic<int> builds = 0;
  const auto got = Race(&cache, kThreads, absl::CancelledError("stopped"), &builds);
  EXPECT_GE(builds, 1);  // a thread that came after the failure built again
  for (const auto& v : got) EXPECT_EQ(v.status(), absl::CancelledError("stopped"));
  EXPECT_EQ(cache.stats().entries, 0u);
  const int before = builds;
  EXPECT_TRUE(cache.GetOrBuild(7, Builder(&builds, "ok", 1)).ok());
  EXPECT_EQ(builds, before + 1);
}

// A build that throws: the exception reaches its caller, every waiter gets
// an error instead of waiting for ever, and the next call builds again.
TEST(BoundedCacheTest, BuildThatThrowsReleasesItsWaiters) {
  Cache cache({});
  absl::Notification building;
  absl::Notification throw_now;
  std::thread builder([&] {
    EXPECT_THROW(cache.GetOrBuild(7,
                                  [&]() -> absl::StatusOr<Cache::Built> {
                                    building.Notify();
                                    throw_now.WaitForNotification();
                                    throw std::bad_alloc();
                                  }),
                 std::bad_alloc);
  });
  building.WaitForNotification();
  absl::StatusOr<std::shared_ptr<const std::string>> waited;
  std::thread waiter([&] {
    waited = cache.GetOrBuild(7, []() -> absl::StatusOr<Cache::Built> {
      return absl::UnknownError("a waiter that came after the throw would build; see below");
    });
  });
  // Give the waiter time to reach the cache: if it comes late it builds
  // itself, and gets its own error, which the assertions below allow for.
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  throw_now.Notify();
  builder.join();
  waiter.join();
  EXPECT_FALSE(waited.ok());
  EXPECT_EQ(cache.stats().entries, 0u);
  std::atomic<int> builds = 0;
  absl::StatusOr<std::shared_ptr<const std::string>> again =
      cache.GetOrBuild(7, Builder(&builds, "ok", 1));
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(**again, "ok");
  EXPECT_EQ(builds, 1);
}

TEST(BoundedCacheTest, EntriesOfAFreedOwnerAreStale) {
  Cache cache({.max_bytes = 100});
  std::atomic<int> builds = 0;
  auto owner = std::make_shared<const int>(1);
  ASSERT_TRUE(cache.GetOrBuild(1, Builder(&builds, "a", 40), owner).ok());
  EXPECT_EQ(owner.use_count(), 1);  // not kept alive
  ASSERT_TRUE(cache.GetOrBuild(1, Builder(&builds, "a", 40), owner).ok());
  EXPECT_EQ(builds, 1);
  owner.reset();
  EXPECT_EQ(cache.stats().bytes, 40u);  // dropped at the next insertion
  ASSERT_TRUE(cache.GetOrBuild(2, Builder(&builds, "b", 10)).ok());
  EXPECT_EQ(cache.stats().bytes, 10u);
  EXPECT_EQ(cache.stats().evictions, 0u);  // stale entries are not evictions
  EXPECT_EQ(cache.Find(1), nullptr);
}

TEST(HashMixTest, KnownValues) {
  // Pinned: tables index by these values, and their contents are compared
  // bit for bit across builds.
  static_assert(Mix64(0) == 0);
  EXPECT_EQ(Mix64(1), 0xccde22c1faa4d20fULL);
  EXPECT_EQ(Mix64(0x123456789abcdefULL), 0x0eb3513c40b11a29ULL);
  EXPECT_NE(Mix64(1), Mix64(2));
}

}  // namespace
}  // namespace riskplan
