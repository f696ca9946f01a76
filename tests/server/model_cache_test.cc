// RiskModelCache and winds (risk model version 3): a wind's model borrows the
// default model's kernel weights and is charged only its kernel headers and
// its glide layer; a flood of distinct winds stays within the cache's bound;
// a second request in the same wind is a hit; a calm wind (W = 0) is the
// default model; the goal-tree key tells winds apart.
#include "server/models/model_cache.h"

#include <memory>
#include <vector>

#include "gtest/gtest.h"
#include "server/models/goal_tree_cache.h"
#include "tests/core/test_maps.h"

namespace riskplan::server {
namespace {

// 3 km x 3 km of 10 m cells, flat, with one landing site in the middle, so
// that every wind has a glide layer of its own (spec section 6).
std::unique_ptr<MapRegistry> Registry() {
  auto registry = MapRegistry::FromMaps({testing_maps::UniformMap(
      300, 300, 10.0, 0.001f, 2.0f, 100.0f, {{"field", 150, 150}}, "wind-city")});
  EXPECT_TRUE(registry.ok()) << registry.status();
  return *std::move(registry);
}

ModelParams Wind(double speed, double from_deg) {
  ModelParams p;
  p.wind_speed_mps = speed;
  p.wind_from_deg = from_deg;
  return p;
}

TEST(ModelCacheWindTest, AWindsModelBorrowsTheDefaultKernelWeights) {
  auto registry = Registry();
  auto cache = RiskModelCache::Create(*registry, 4);
  ASSERT_TRUE(cache.ok()) << cache.status();
  const RiskMap& map = *registry->maps().front();
  const std::shared_ptr<const RiskModel> calm = (*cache)->Default(map);
  auto wind = (*cache)->Get(map, Wind(8.0, 270.0));
  ASSERT_TRUE(wind.ok()) << wind.status();
  // Its own table (the wind's offsets and energies) over the same weights.
  EXPECT_NE(&(*wind)->table(), &calm->table());
  const ImpactTable& a = calm->table();
  const ImpactTable& b = (*wind)->table();
  ASSERT_EQ(a.height_bins(), b.height_bins());
  for (int bin = 1; bin <= a.height_bins(); bin += 7) {
    for (int k = 0; k < a.heading_bins(); k += 5) {
      EXPECT_EQ(a.kernel(bin, k).weights, b.kernel(bin, k).weights);
    }
  }
  // Its own glide layer, and charged it and the headers only.
  EXPECT_GT((*wind)->GlideBytes(), 0u);
  const size_t charged = (*wind)->MemoryBytes() - b.WeightBytes();
  EXPECT_EQ(RiskModelCache::ChargedBytes(**wind, &calm->table()), charged);
  const RiskModelCache::Stats s = (*cache)->stats();
  EXPECT_EQ(s.overridden_bytes, charged);
  // The glide layer, the kernel headers and the air-heading bins (4096
  // entries of 2 bytes).
  EXPECT_EQ(charged, (*wind)->GlideBytes() + (b.MemoryBytes() - b.WeightBytes()) + 4096 * 2);
  EXPECT_LT(charged, a.WeightBytes());
}

TEST(ModelCacheWindTest, ASecondRequestInTheSameWindIsAHit) {
  auto registry = Registry();
  auto cache = RiskModelCache::Create(*registry, 4);
  ASSERT_TRUE(cache.ok());
  const RiskMap& map = *registry->maps().front();
  auto first = (*cache)->Get(map, Wind(8.0, 0.0));
  ASSERT_TRUE(first.ok());
  EXPECT_EQ((*cache)->stats().builds, 1u);
  auto second = (*cache)->Get(map, Wind(8.0, 0.0));
  ASSERT_TRUE(second.ok());
  EXPECT_EQ(first->get(), second->get());
  EXPECT_EQ((*cache)->stats().builds, 1u);
  EXPECT_EQ((*cache)->stats().hits, 1u);
  EXPECT_EQ((*cache)->Peek(map, Wind(8.0, 0.0)).get(), first->get());
  // 360 degrees is the same wind, but another fingerprint (the parameter as
  // given): it is built again, to the same numbers.
  auto turned = (*cache)->Get(map, Wind(8.0, 360.0));
  ASSERT_TRUE(turned.ok());
  EXPECT_EQ((*turned)->table().kernel(10, 3).offset_x_m, (*first)->table().kernel(10, 3).offset_x_m);
  EXPECT_EQ((*turned)->table().kernel(10, 3).offset_y_m, (*first)->table().kernel(10, 3).offset_y_m);
}

TEST(ModelCacheWindTest, ACalmWindIsTheDefaultModel) {
  auto registry = Registry();
  auto cache = RiskModelCache::Create(*registry, 4);
  ASSERT_TRUE(cache.ok());
  const RiskMap& map = *registry->maps().front();
  auto calm = (*cache)->Get(map, ModelParams{});
  ASSERT_TRUE(calm.ok());
  EXPECT_EQ(calm->get(), (*cache)->Default(map).get());
  EXPECT_EQ((*cache)->stats().builds, 0u);
}

// A flood of requests, each in a wind of its own: the cache keeps at most
// its bound of models, charged at most that many winds' headers and glide
// layers, and the evicted models are freed once nobody holds them.
TEST(ModelCacheWindTest, AFloodOfDistinctWindsStaysWithinTheBound) {
  auto registry = Registry();
  constexpr size_t kBound = 3;
  auto cache = RiskModelCache::Create(*registry, kBound);
  ASSERT_TRUE(cache.ok());
  const RiskMap& map = *registry->maps().front();
  std::vector<std::weak_ptr<const RiskModel>> built;
  size_t largest = 0;
  for (int k = 0; k < 24; ++k) {
    auto model = (*cache)->Get(map, Wind(1.0 + 0.3 * k, 15.0 * k));
    ASSERT_TRUE(model.ok()) << model.status();
    built.push_back(*model);
    largest = std::max(largest,
                       RiskModelCache::ChargedBytes(**model, &(*cache)->Default(map)->table()));
    const RiskModelCache::Stats s = (*cache)->stats();
    EXPECT_LE(s.overridden_cached, kBound);
    EXPECT_LE(s.overridden_bytes, kBound * largest);
  }
  const RiskModelCache::Stats s = (*cache)->stats();
  EXPECT_EQ(s.builds, 24u);
  EXPECT_EQ(s.evictions, 24u - kBound);
  EXPECT_EQ(s.overridden_cached, kBound);
  // Far less than a table of weights per wind.
  EXPECT_LT(s.overridden_bytes, (*cache)->Default(map)->table().WeightBytes());
  size_t alive = 0;
  for (const auto& w : built) alive += w.expired() ? 0 : 1;
  EXPECT_EQ(alive, kBound);
}

// The goal-tree cache's key holds every model parameter: two winds, or the
// same wind from another direction, never share a tree.
TEST(ModelCacheWindTest, GoalTreeKeysTellWindsApart) {
  GoalTreeKey a;
  a.map_name = "wind-city";
  a.goal = Pose{100.0, 200.0, 150.0, 0.5};
  GoalTreeKey b = a;
  b.model_params = Wind(8.0, 270.0);
  GoalTreeKey c = a;
  c.model_params = Wind(8.0, 0.0);
  GoalTreeKey d = a;
  d.model_params = Wind(8.0, 270.0);
  d.model_params.glide_airspeed_mps = 14.0;
  EXPECT_NE(a.Encode(), b.Encode());
  EXPECT_NE(b.Encode(), c.Encode());
  EXPECT_NE(b.Encode(), d.Encode());
  GoalTreeKey e = a;
  e.model_params = Wind(8.0, 270.0);
  EXPECT_EQ(b.Encode(), e.Encode());
}

}  // namespace
}  // namespace riskplan::server
