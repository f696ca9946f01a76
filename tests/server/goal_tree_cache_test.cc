#include "server/models/goal_tree_cache.h"

#include <cmath>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "gtest/gtest.h"

namespace riskplan::server {
namespace {

GoalTreeKey Key(double goal_x = 100.0) {
  GoalTreeKey key;
  key.map_name = "demo-city";
  key.map_identity = 0x1000;
  key.goal = Pose{goal_x, 200.0, 150.0, 0.5};
  key.planner_params = {{"step_m", 300.0}};
  key.seed = 7;
  return key;
}

std::shared_ptr<const GoalTree> Tree(size_t nodes) {
  auto tree = std::make_shared<GoalTree>();
  tree->nodes.resize(nodes);
  tree->nodes.shrink_to_fit();
  for (size_t i = 1; i < nodes; ++i) tree->nodes[i].parent = 0;
  return tree;
}

size_t Bytes(const GoalTreeKey& key, size_t nodes) {
  return GoalTreeCache::TreeBytes(*Tree(nodes), key.Encode().size());
}

TEST(GoalTreeCacheTest, AMissThenAHitOfTheSameTree) {
  GoalTreeCache cache(1 << 20);
  EXPECT_EQ(cache.Find(Key()), nullptr);
  auto tree = Tree(10);
  cache.Put(Key(), tree);
  EXPECT_EQ(cache.Find(Key()), tree);  // the same shared tree, not a copy
  const GoalTreeCache::Stats s = cache.stats();
  EXPECT_EQ(s.hits, 1u);
  EXPECT_EQ(s.misses, 1u);
  EXPECT_EQ(s.entries, 1u);
  EXPECT_EQ(s.bytes, Bytes(Key(), 10));
  EXPECT_EQ(s.evictions, 0u);
}

TEST(GoalTreeCacheTest, EveryComponentOfTheKeyTellsTreesApart) {
  GoalTreeCache cache(1 << 20);
  cache.Put(Key(), Tree(10));
  std::vector<GoalTreeKey> others(7, Key());
  others[0].map_name = "other-city";
  others[1].map_identity = 0x2000;
  others[2].goal.theta = std::nextafter(0.5, 1.0);  // one bit of the goal
  others[3].model_params.mass_kg = 11.0;
  others[4].planner_params["step_m"] = 301.0;
  others[5].planner_params["k_near"] = 6.0;
  others[6].seed = 8;
  for (size_t k = 0; k < others.size(); ++k) {
    SCOPED_TRACE(testing::Message() << "variant " << k);
    EXPECT_NE(others[k].Encode(), Key().Encode());
    EXPECT_EQ(cache.Find(others[k]), nullptr);
  }
  EXPECT_EQ(cache.stats().misses, others.size());
  EXPECT_EQ(cache.stats().hits, 0u);
  EXPECT_NE(cache.Find(Key()), nullptr);
}

TEST(GoalTreeCacheTest, TheLargerTreeStays) {
  GoalTreeCache cache(1 << 20);
  auto large = Tree(50);
  cache.Put(Key(), large);
  cache.Put(Key(), Tree(20));  // a fleet that began from less
  EXPECT_EQ(cache.Find(Key()), large);
  auto larger = Tree(80);
  cache.Put(Key(), larger);
  EXPECT_EQ(cache.Find(Key()), larger);
  EXPECT_EQ(cache.stats().entries, 1u);
  EXPECT_EQ(cache.stats().bytes, Bytes(Key(), 80));
}

TEST(GoalTreeCacheTest, TheLeastRecentlyUsedTreeGoesFirst) {
  const size_t one = Bytes(Key(1.0), 100);
  // Room for exactly three trees of 100 nodes (goals that are powers of two:
  // keys of one length).
  GoalTreeCache cache(3 * one);
  cache.Put(Key(1.0), Tree(100));
  cache.Put(Key(2.0), Tree(100));
  cache.Put(Key(4.0), Tree(100));
  EXPECT_EQ(cache.stats().bytes, 3 * one);  // at the bound: nothing evicted
  EXPECT_EQ(cache.stats().evictions, 0u);
  ASSERT_NE(cache.Find(Key(1.0)), nullptr);  // 1 is now the most recent
  cache.Put(Key(8.0), Tree(100));            // over: 2 goes
  EXPECT_EQ(cache.stats().evictions, 1u);
  EXPECT_EQ(cache.stats().entries, 3u);
  EXPECT_EQ(cache.Find(Key(2.0)), nullptr);
  EXPECT_NE(cache.Find(Key(1.0)), nullptr);
  EXPECT_NE(cache.Find(Key(4.0)), nullptr);
  EXPECT_NE(cache.Find(Key(8.0)), nullptr);
  // A tree larger than one and smaller than two goes in, and the two least
  // recent (1, then 4) out.
  cache.Put(Key(16.0), Tree(150));
  EXPECT_LE(cache.stats().bytes, 3 * one);
  EXPECT_EQ(cache.Find(Key(1.0)), nullptr);
  EXPECT_EQ(cache.Find(Key(4.0)), nullptr);
  EXPECT_NE(cache.Find(Key(8.0)), nullptr);
  EXPECT_NE(cache.Find(Key(16.0)), nullptr);
  EXPECT_EQ(cache.stats().evictions, 3u);
}

TEST(GoalTreeCacheTest, TheMemoryBoundAtUnderAndOver) {
  const size_t bytes = Bytes(Key(), 100);
  {
    GoalTreeCache at(bytes);  // exactly at the bound: kept
    at.Put(Key(), Tree(100));
    EXPECT_EQ(at.stats().entries, 1u);
    EXPECT_EQ(at.stats().bytes, bytes);
  }
  {
    GoalTreeCache under(bytes + 1);
    under.Put(Key(), Tree(100));
    EXPECT_EQ(under.stats().entries, 1u);
  }
  {
    GoalTreeCache over(bytes - 1);  // one tree larger than the whole cache
    over.Put(Key(), Tree(100));
    EXPECT_EQ(over.stats().entries, 0u);
    EXPECT_EQ(over.stats().bytes, 0u);
    EXPECT_EQ(over.stats().evictions, 0u);
    EXPECT_EQ(over.Find(Key()), nullptr);
  }
}

TEST(GoalTreeCacheTest, TheEstimateGrowsWithTheNodes) {
  const GoalTreeKey key = Key();
  EXPECT_EQ(Bytes(key, 1000) - Bytes(key, 0 + 1), 999 * sizeof(GoalTreeNode));
}

// Readers keep the tree they found while other threads insert and evict.
TEST(GoalTreeCacheTest, ConcurrentFindsAndPutsKeepTheBound) {
  const size_t one = Bytes(Key(0.0), 64);
  GoalTreeCache cache(4 * one);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&cache, t] {
      for (int i = 0; i < 500; ++i) {
        const GoalTreeKey key = Key(static_cast<double>((i + t) % 8));
        std::shared_ptr<const GoalTree> found = cache.Find(key);
        if (found != nullptr) {
          EXPECT_EQ(found->nodes.size() % 64, 0u);
        }
        cache.Put(key, Tree(64 * (1 + i % 2)));
      }
    });
  }
  for (std::thread& th : threads) th.join();
  const GoalTreeCache::Stats s = cache.stats();
  EXPECT_LE(s.bytes, 4 * one);
  EXPECT_EQ(s.hits + s.misses, 2000u);
}

}  // namespace
}  // namespace riskplan::server
