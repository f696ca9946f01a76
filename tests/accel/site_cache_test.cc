// The exact site cache: keys, sessions and epochs, and lock-free use from
// several threads.
#include "accel/site_cache.h"

#include <bit>
#include <thread>
#include <vector>

#include "accel_test_util.h"
#include "core/base/random.h"
#include "gtest/gtest.h"

namespace riskplan::accel {
namespace {

TEST(SiteCacheTest, StoresAndFindsExactValues) {
  SiteCache cache(1 << 20);
  ASSERT_TRUE(cache.enabled());
  EXPECT_EQ(cache.capacity_bytes(), size_t{1} << 20);
  const SiteCache::Session s = cache.Begin(*testing::SmallCity());
  EXPECT_NE(s.tag, 0u);
  const KernelSite site{20, 5, 300, -40};
  const uint64_t key = SiteCache::KeyOf(s, site);
  ASSERT_NE(key, 0u);
  SiteCache::Values v;
  EXPECT_FALSE(cache.Lookup(s, key, &v));
  cache.Insert(s, key, {0.1, 7.25, 1.0 / 3.0});
  ASSERT_TRUE(cache.Lookup(s, key, &v));
  EXPECT_EQ(v.impact_factor, 0.1);
  EXPECT_EQ(v.expected_shelter, 7.25);
  EXPECT_EQ(v.casualty_probability, 1.0 / 3.0);
  // Another site is another key.
  EXPECT_NE(SiteCache::KeyOf(s, {20, 5, 301, -40}), key);
  EXPECT_NE(SiteCache::KeyOf(s, {21, 5, 300, -40}), key);
  // Sites that do not fit bypass the cache.
  EXPECT_EQ(SiteCache::KeyOf(s, {200, 5, 300, 40}), 0u);
  EXPECT_EQ(SiteCache::KeyOf(s, {20, 5, 70000, 40}), 0u);
  // The same model gets the same tag.
  EXPECT_EQ(cache.Begin(*testing::SmallCity()).tag, s.tag);
}

TEST(SiteCacheTest, DisabledBelowOneEntry) {
  SiteCache cache(16);
  EXPECT_FALSE(cache.enabled());
  EXPECT_EQ(SiteCache::KeyOf(cache.Begin(*testing::SmallCity()), {1, 1, 1, 1}), 0u);
}

TEST(SiteCacheTest, ModelsAreToldApartAndTagsRunOutSafely) {
  // Three models with different casualty energies, two tags available.
  auto base = testing::SmallCity();
  std::vector<std::shared_ptr<const RiskModel>> models = {base};
  for (double beta : {150.0, 200.0}) {
    ModelParams p = base->params();
    p.beta_j = beta;
    models.push_back(*RiskModel::Create(base->map_ptr(), p));
  }
  SiteCache cache(1 << 16, 2);
  const SiteCache::Session a = cache.Begin(*models[0]);
  const SiteCache::Session b = cache.Begin(*models[1]);
  EXPECT_NE(a.tag, b.tag);
  const KernelSite site{10, 3, 50, 60};
  cache.Insert(a, SiteCache::KeyOf(a, site), {1.0, 2.0, 0.5});
  SiteCache::Values v;
  EXPECT_FALSE(cache.Lookup(b, SiteCache::KeyOf(b, site), &v));
  ASSERT_TRUE(cache.Lookup(a, SiteCache::KeyOf(a, site), &v));
  // The third model exhausts the tags: the table is cleared, a new epoch
  // begins, and the old sessions can neither read nor write any more.
  const SiteCache::Session c = cache.Begin(*models[2]);
  EXPECT_EQ(cache.epoch(), 1u);
  EXPECT_FALSE(cache.Lookup(a, SiteCache::KeyOf(a, site), &v));
  cache.Insert(a, SiteCache::KeyOf(a, site), {9.0, 9.0, 0.9});
  EXPECT_EQ(c.tag, a.tag);  // reused, in the new epoch
  EXPECT_FALSE(cache.Lookup(c, SiteCache::KeyOf(c, site), &v));
}

TEST(SiteCacheTest, ConcurrentReadersNeverSeeAnotherKeysValues) {
  // A tiny table, so that threads fight over the same slots: every hit must
  // return exactly the values that belong to its key.
  SiteCache cache(64 * 32);
  const SiteCache::Session s = cache.Begin(*testing::SmallCity());
  const auto values_of = [](uint64_t key) {
    return SiteCache::Values{static_cast<double>(key % 1000003), static_cast<double>(key % 997),
                             static_cast<double>(key % 89)};
  };
  std::atomic<uint64_t> hits{0}, wrong{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&, t] {
      Rng rng(t);
      for (int n = 0; n < 200000; ++n) {
        const KernelSite site{1 + static_cast<int>(rng.Uniform() * 3), 0,
                              static_cast<int>(rng.Uniform() * 40), 7};
        const uint64_t key = SiteCache::KeyOf(s, site);
        SiteCache::Values v;
        if (cache.Lookup(s, key, &v)) {
          ++hits;
          const SiteCache::Values want = values_of(key);
          if (v.impact_factor != want.impact_factor ||
              v.expected_shelter != want.expected_shelter ||
              v.casualty_probability != want.casualty_probability) {
            ++wrong;
          }
        } else {
          cache.Insert(s, key, values_of(key));
        }
      }
    });
  }
  for (std::thread& t : threads) t.join();
  EXPECT_GT(hits.load(), 1000u);
  EXPECT_EQ(wrong.load(), 0u);
}

}  // namespace
}  // namespace riskplan::accel
