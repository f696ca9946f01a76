#include "server/api/proto_convert.h"

#include <cmath>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "server/models/feasibility_cache.h"
#include "server/models/model_cache.h"
#include "tests/core/test_maps.h"

namespace riskplan::server {
namespace {

std::shared_ptr<const RiskMap> SmallMap() {
  // 10 x 6 cells of 10 m; density rises with the column, no-fly at (9, 5).
  MapHeader header;
  header.name = "small";
  header.res = 10.0;
  header.nx = 10;
  header.ny = 6;
  header.x0 = 1000.0;
  header.y0 = 2000.0;
  MapLayers layers;
  for (int j = 0; j < 6; ++j) {
    for (int i = 0; i < 10; ++i) {
      layers.density.push_back(static_cast<float>(i));
      layers.shelter.push_back(1.0f);
      layers.terrain.push_back(static_cast<float>(100 + j));
      layers.nofly.push_back(i == 9 && j == 5 ? 1 : 0);
    }
  }
  layers.landing_sites = {{"field", 2, 3}};
  auto map = RiskMap::Create(header, layers);
  EXPECT_TRUE(map.ok()) << map.status();
  return *map;
}

TEST(ProtoConvertTest, DownsampleAveragesBlocksAndKeepsPartialEdges) {
  auto map = SmallMap();
  v1::GetMapLayerResponse r = DownsampleLayer(*map, v1::POPULATION_DENSITY, 4);
  EXPECT_EQ(r.factor(), 3);  // ceil(10 / 4)
  EXPECT_EQ(r.nx(), 4);      // ceil(10 / 3)
  EXPECT_EQ(r.ny(), 2);      // ceil(6 / 3)
  EXPECT_DOUBLE_EQ(r.cell_m(), 30.0);
  EXPECT_DOUBLE_EQ(r.x0_m(), 1000.0);
  ASSERT_EQ(r.values_size(), 8);
  EXPECT_FLOAT_EQ(r.values(0), 1.0f);  // columns 0..2
  EXPECT_FLOAT_EQ(r.values(1), 4.0f);  // columns 3..5
  EXPECT_FLOAT_EQ(r.values(3), 9.0f);  // column 9 alone (partial block)

  v1::GetMapLayerResponse nofly = DownsampleLayer(*map, v1::NO_FLY, 4);
  EXPECT_FLOAT_EQ(nofly.values(7), 1.0f);  // the block holding (9, 5)
  EXPECT_FLOAT_EQ(nofly.values(3), 0.0f);

  v1::GetMapLayerResponse terrain = DownsampleLayer(*map, v1::TERRAIN, 100);
  EXPECT_EQ(terrain.factor(), 1);
  EXPECT_FLOAT_EQ(terrain.values(5 * 10 + 0), 105.0f);
}

TEST(ProtoConvertTest, MapInfo) {
  auto map = SmallMap();
  v1::MapInfo info = MapInfoFromMap(*map);
  EXPECT_EQ(info.name(), "small");
  EXPECT_EQ(info.nx(), 10);
  EXPECT_EQ(info.ny(), 6);
  EXPECT_DOUBLE_EQ(info.width_m(), 100.0);
  EXPECT_DOUBLE_EQ(info.height_m(), 60.0);
  EXPECT_DOUBLE_EQ(info.terrain_min_m(), 100.0);
  EXPECT_DOUBLE_EQ(info.terrain_max_m(), 105.0);
  ASSERT_EQ(info.landing_sites_size(), 1);
  EXPECT_EQ(info.landing_sites(0).name(), "field");
  EXPECT_DOUBLE_EQ(info.landing_sites(0).x(), 1025.0);
  EXPECT_DOUBLE_EQ(info.landing_sites(0).y(), 2035.0);
  EXPECT_DOUBLE_EQ(info.landing_sites(0).terrain_m(), 103.0);
  EXPECT_EQ(info.memory_bytes(), static_cast<int64_t>(map->MemoryBytes()));
}

TEST(ProtoConvertTest, TrajectoryPathIsSampledAndEndsAtTheGoal) {
  PlanImprovement improvement;
  improvement.waypoints = {{0, 0, 200, 0}, {1000, 0, 200, 0}, {2000, 500, 210, 0.5}};
  improvement.risk = 1e-7;
  improvement.length_m = 1234.0;
  improvement.iterations = 42;
  v1::Trajectory t;
  ASSERT_TRUE(TrajectoryToProto(improvement, ModelParams{}, 25.0, nullptr, &t).ok());
  EXPECT_EQ(t.waypoints_size(), 3);
  EXPECT_EQ(t.risk(), 1e-7);
  EXPECT_EQ(t.found_at_iteration(), 42);
  ASSERT_GE(t.path_size(), 2);
  EXPECT_DOUBLE_EQ(t.path(0).x(), 0.0);
  const v1::Pose& last = t.path(t.path_size() - 1);
  EXPECT_NEAR(last.x(), 2000.0, 1e-6);
  EXPECT_NEAR(last.y(), 500.0, 1e-6);
  EXPECT_NEAR(last.z(), 210.0, 1e-6);
  // About one pose per 25 m of a path a little over 2 km.
  EXPECT_GT(t.path_size(), 2000 / 25);
  EXPECT_LT(t.path_size(), 3000 / 25);
  for (int i = 1; i + 1 < t.path_size(); ++i) {
    const double step =
        std::hypot(t.path(i).x() - t.path(i - 1).x(), t.path(i).y() - t.path(i - 1).y());
    EXPECT_LE(step, 25.0 + 1e-6);
  }
}

TEST(ProtoConvertTest, ImprovementUpdate) {
  PlanImprovement improvement;
  improvement.waypoints = {{0, 0, 200, 0}, {1000, 0, 200, 0}};
  improvement.risk = 2e-7;
  improvement.iterations = 7;
  improvement.tree_size = 30;
  improvement.elapsed_s = 0.25;
  absl::StatusOr<v1::PlanUpdate> update = ImprovementToProto(improvement, ModelParams{}, 25.0);
  ASSERT_TRUE(update.ok()) << update.status();
  EXPECT_FALSE(update->final());
  EXPECT_EQ(update->iterations(), 7);
  EXPECT_EQ(update->tree_size(), 30);
  EXPECT_DOUBLE_EQ(update->elapsed_s(), 0.25);
  EXPECT_EQ(update->trajectory().waypoints_size(), 2);
  EXPECT_EQ(update->trajectory().risk(), 2e-7);
  EXPECT_GE(update->trajectory().path_size(), 2);
}

TEST(ProtoConvertTest, ImprovementThatDoesNotConvertIsAnInternalErrorNamingIt) {
  PlanImprovement improvement;
  improvement.waypoints = {{0, 0, 200, 0}};  // one waypoint makes no piece
  improvement.iterations = 9;
  absl::StatusOr<v1::PlanUpdate> update = ImprovementToProto(improvement, ModelParams{}, 25.0);
  ASSERT_FALSE(update.ok());
  EXPECT_EQ(update.status().code(), absl::StatusCode::kInternal);
  EXPECT_THAT(std::string(update.status().message()),
              ::testing::HasSubstr("improvement found at iteration 9 (1 waypoints)"));
}

TEST(ProtoConvertTest, FinalUpdateWithTrajectoryAndTruncatedTree) {
  PlanResult result;
  result.reason = StopReason::kBudgetExhausted;
  result.best = PlanImprovement{.waypoints = {{0, 0, 200, 0}, {1000, 0, 200, 0}}, .risk = 3e-7};
  result.iterations = 100;
  result.tree_size = 60000;
  result.elapsed_s = 1.5;
  result.configurations_evaluated = 12345;
  result.tree.resize(kMaxTreeEdges + 1, TreeEdge{{1, 2, 3, 0}, {4, 5, 6, 0}});
  absl::StatusOr<v1::PlanUpdate> update =
      FinalUpdateToProto(result, v1::BUDGET_EXHAUSTED, ModelParams{}, 25.0, true);
  ASSERT_TRUE(update.ok()) << update.status();
  EXPECT_TRUE(update->final());
  EXPECT_EQ(update->end_reason(), v1::BUDGET_EXHAUSTED);
  EXPECT_EQ(update->iterations(), 100);
  EXPECT_EQ(update->tree_size(), 60000);
  EXPECT_EQ(update->configurations_evaluated(), 12345u);
  EXPECT_EQ(update->trajectory().risk(), 3e-7);
  EXPECT_EQ(update->tree_edges_size(), static_cast<int>(kMaxTreeEdges));
  EXPECT_TRUE(update->tree_truncated());
  EXPECT_DOUBLE_EQ(update->tree_edges(0).to().y(), 5.0);

  // Without the tree asked for, and without a solution.
  result.best.reset();
  update = FinalUpdateToProto(result, v1::SHUTDOWN, ModelParams{}, 25.0, false);
  ASSERT_TRUE(update.ok()) << update.status();
  EXPECT_EQ(update->end_reason(), v1::SHUTDOWN);
  EXPECT_FALSE(update->has_trajectory());
  EXPECT_EQ(update->tree_edges_size(), 0);
  EXPECT_FALSE(update->tree_truncated());
}

TEST(ProtoConvertTest, FinalUpdateWhoseBestDoesNotConvertIsAnInternalErrorNamingIt) {
  PlanResult result;
  result.reason = StopReason::kConverged;
  result.best = PlanImprovement{.waypoints = {{0, 0, 200, 0}, {1000, 0, NAN, 0}}, .iterations = 5};
  absl::StatusOr<v1::PlanUpdate> update =
      FinalUpdateToProto(result, v1::CONVERGED, ModelParams{}, 25.0, false);
  ASSERT_FALSE(update.ok());
  EXPECT_EQ(update.status().code(), absl::StatusCode::kInternal);
  EXPECT_THAT(std::string(update.status().message()),
              ::testing::HasSubstr("final message's best trajectory (found at iteration 5"));
}

// The front and the limits' report: every front point a Trajectory with its
// exact numbers and a path to draw; the note of a plan the limits emptied.
TEST(ProtoConvertTest, FrontAndLimitReport) {
  PlanResult result;
  result.reason = StopReason::kNoSolution;
  result.front = {FrontPoint{.waypoints = {{0, 0, 200, 0}, {1000, 0, 200, 0}},
                             .risk = 2e-7, .length_m = 1000, .flight_time_s = 55.5},
                  FrontPoint{.waypoints = {{0, 0, 200, 0}, {500, 500, 200, 0}, {1000, 0, 200, 0}},
                             .risk = 1e-7, .length_m = 1500, .flight_time_s = 83.3}};
  result.limits.candidates = 7;
  result.limits.rejected = 7;
  result.limits.fastest_flight_time_s = 55.5;
  result.limits.note = "no trajectory within the endurance (max_flight_time_s = 10 s): ...";
  absl::StatusOr<v1::PlanUpdate> update =
      FinalUpdateToProto(result, v1::NO_SOLUTION, ModelParams{}, 25.0, false);
  ASSERT_TRUE(update.ok()) << update.status();
  ASSERT_EQ(update->front_size(), 2);
  EXPECT_EQ(update->front(0).risk(), 2e-7);
  EXPECT_EQ(update->front(1).risk(), 1e-7);
  EXPECT_EQ(update->front(1).waypoints_size(), 3);
  EXPECT_GT(update->front(0).path_size(), 2);
  EXPECT_GT(update->front(0).flight_time_s(), 0.0);
  EXPECT_EQ(update->limits().candidates(), 7);
  EXPECT_EQ(update->limits().fastest_flight_time_s(), 55.5);
  EXPECT_THAT(update->limits().note(), ::testing::HasSubstr("no trajectory within the endurance"));
  // No limits: no report.
  update = FinalUpdateToProto(PlanResult{}, v1::NO_SOLUTION, ModelParams{}, 25.0, false);
  ASSERT_TRUE(update.ok());
  EXPECT_FALSE(update->has_limits());
  EXPECT_EQ(update->front_size(), 0);
}

TEST(ProtoConvertTest, EndReasons) {
  EXPECT_EQ(EndReasonToProto(StopReason::kBudgetExhausted, false), v1::BUDGET_EXHAUSTED);
  EXPECT_EQ(EndReasonToProto(StopReason::kConverged, true), v1::CONVERGED);
  EXPECT_EQ(EndReasonToProto(StopReason::kCancelled, false), v1::CANCELLED);
  EXPECT_EQ(EndReasonToProto(StopReason::kCancelled, true), v1::SHUTDOWN);
  EXPECT_EQ(EndReasonToProto(StopReason::kNoSolution, false), v1::NO_SOLUTION);
  EXPECT_EQ(EndReasonToProto(StopReason::kNoSolution, true), v1::SHUTDOWN);
}

TEST(ModelCacheTest, DefaultModelIsSharedAndOverridesAreCachedWithLruBound) {
  auto registry = MapRegistry::FromMaps({SmallMap()});
  ASSERT_TRUE(registry.ok());
  auto cache = RiskModelCache::Create(**registry, /*max_overridden=*/2);
  ASSERT_TRUE(cache.ok()) << cache.status();
  const RiskMap& map = *(*registry)->maps().front();

  auto def = (*cache)->Get(map, ModelParams{});
  ASSERT_TRUE(def.ok());
  EXPECT_EQ(*def, (*cache)->Default(map));
  EXPECT_EQ((*cache)->Peek(map, ModelParams{}), *def);

  ModelParams a;
  a.min_agl_m = 40;  // same impact table as the default
  EXPECT_EQ((*cache)->Peek(map, a), nullptr);
  auto model_a = (*cache)->Get(map, a);
  ASSERT_TRUE(model_a.ok());
  EXPECT_NE(*model_a, *def);
  EXPECT_EQ((*model_a)->table_ptr(), (*def)->table_ptr());  // shared, not rebuilt
  EXPECT_EQ((*cache)->Peek(map, a), *model_a);

  ModelParams b;
  b.mass_kg = 5;  // a new impact table
  auto model_b = (*cache)->Get(map, b);
  ASSERT_TRUE(model_b.ok());
  EXPECT_NE((*model_b)->table_ptr(), (*def)->table_ptr());
  EXPECT_EQ((*cache)->Get(map, b).value(), *model_b);

  ModelParams c;
  c.mass_kg = 6;
  ASSERT_TRUE((*cache)->Get(map, c).ok());
  // Three overrides, room for two: the least recently used (a) is gone.
  EXPECT_EQ((*cache)->Peek(map, a), nullptr);
  EXPECT_NE((*cache)->Peek(map, b), nullptr);
  RiskModelCache::Stats stats = (*cache)->stats();
  EXPECT_EQ(stats.builds, 3u);
  EXPECT_EQ(stats.evictions, 1u);
  EXPECT_EQ(stats.overridden_cached, 2u);
}

TEST(ProtoConvertTest, FeasibilityResult) {
  v1::TwoTierResult out;
  FeasibilityResult feasible;
  feasible.cells_checked = 42;
  FeasibilityToProto(feasible, nullptr, &out);
  EXPECT_TRUE(out.feasible());
  EXPECT_EQ(out.tier(), v1::FEASIBILITY_TIER_UNSPECIFIED);
  EXPECT_EQ(out.segment(), -1);
  EXPECT_EQ(out.cell_i(), -1);
  EXPECT_EQ(out.kind(), v1::VIOLATION_KIND_UNSPECIFIED);
  EXPECT_EQ(out.cells_checked(), 42);
  EXPECT_FALSE(out.has_position());

  FeasibilityResult collision;
  collision.feasible = false;
  collision.tier = FeasibilityTier::kCoarse;
  collision.segment = 3;
  collision.cell_i = 5;
  collision.cell_j = 7;
  collision.position = Point3{1.0, 2.0, 3.0};
  collision.kind = ViolationKind::kTerrainCollision;
  collision.cells_checked = 99;
  FeasibilityToProto(collision, nullptr, &out);
  EXPECT_FALSE(out.feasible());
  EXPECT_EQ(out.tier(), v1::COARSE);
  EXPECT_EQ(out.segment(), 3);
  EXPECT_EQ(out.cell_i(), 5);
  EXPECT_EQ(out.cell_j(), 7);
  EXPECT_EQ(out.position().z(), 3.0);
  EXPECT_EQ(out.kind(), v1::TERRAIN_COLLISION);
  EXPECT_EQ(out.cells_checked(), 99);
  collision.tier = FeasibilityTier::kDetailed;
  FeasibilityToProto(collision, nullptr, &out);
  EXPECT_EQ(out.tier(), v1::DETAILED);
}

TEST(FeasibilityCacheTest, CachesPerModelAndOptionsWithLruBound) {
  auto registry = MapRegistry::FromMaps({SmallMap()});
  ASSERT_TRUE(registry.ok());
  auto models = RiskModelCache::Create(**registry, /*max_overridden=*/2);
  ASSERT_TRUE(models.ok()) << models.status();
  const RiskMap& map = *(*registry)->maps().front();
  std::shared_ptr<const RiskModel> def = (*models)->Default(map);
  ModelParams a;
  a.min_agl_m = 40;
  std::shared_ptr<const RiskModel> model_a = (*models)->Get(map, a).value();

  FeasibilityCache cache(/*capacity=*/2);
  const TwoTierOptions defaults;
  auto first = cache.Get(def, defaults);
  EXPECT_EQ(first->model, def);
  EXPECT_EQ(cache.Get(def, defaults), first);  // a hit
  EXPECT_EQ(cache.stats().hits, 1u);
  EXPECT_EQ(cache.stats().builds, 1u);

  // Other model parameters or other options: another checker.
  auto other_model = cache.Get(model_a, defaults);
  EXPECT_NE(other_model, first);
  EXPECT_EQ(other_model->model, model_a);
  TwoTierOptions coarse8;
  coarse8.block_cells = 8;
  auto other_options = cache.Get(def, coarse8);  // evicts the least recently used
  EXPECT_NE(other_options, first);
  EXPECT_EQ(other_options->checker.options().block_cells, 8);
  EXPECT_EQ(cache.stats().builds, 3u);
  EXPECT_EQ(cache.stats().evictions, 1u);
  EXPECT_EQ(cache.stats().cached, 2u);

  // An evicted checker stays usable by whoever holds it, keeps its model and
  // answers as a fresh one. (On this 100 x 60 m map every cell is within the
  // margin where a fall's impact window may reach past the map, so both
  // paths are infeasible: the first for that, the second under the terrain.)
  const Point3 path[] = {{1010.0, 2010.0, 150.0}, {1080.0, 2040.0, 150.0}};
  const Point3 low[] = {{1010.0, 2010.0, 150.0}, {1080.0, 2040.0, 90.0}};
  const FeasibilityResult fresh = TwoTierFeasibility(*model_a, defaults).CheckPath(path);
  EXPECT_EQ(fresh.kind, ViolationKind::kImpactOutsideMap);
  model_a.reset();
  const FeasibilityResult kept = other_model->checker.CheckPath(path);
  EXPECT_FALSE(kept.feasible);
  EXPECT_EQ(kept.kind, fresh.kind);
  EXPECT_EQ(kept.cell_i, fresh.cell_i);
  EXPECT_EQ(kept.cell_j, fresh.cell_j);
  EXPECT_FALSE(other_model->checker.CheckPath(low).feasible);
}

}  // namespace
}  // namespace riskplan::server
