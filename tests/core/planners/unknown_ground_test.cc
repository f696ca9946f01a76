// Spec version 2 across the planners: what lies outside the map can never
// change an admissible trajectory's risk, and no planner flies where a fall's
// impact window would reach past the map.
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "core/flight/trajectory.h"
#include "core/map/demo_city.h"
#include "core/planners/planner.h"
#include "gtest/gtest.h"
#include "tests/core/planner_test_util.h"
#include "tests/core/seed_planner_test_util.h"

namespace riskplan {
namespace {

// `map` with `pad` cells of other data on every side: the same cells at the
// same coordinates (the origin moves out by pad cells), with `density`,
// `shelter` and `terrain(i, j)` outside. The padding is no-fly when `nofly`,
// which keeps every glide inside the original map.
template <typename TerrainFn>
std::shared_ptr<const RiskMap> Padded(const RiskMap& map, int pad, float density, float shelter,
                                      TerrainFn terrain, bool nofly) {
  MapHeader header = map.header();
  header.nx = map.nx() + 2 * pad;
  header.ny = map.ny() + 2 * pad;
  header.x0 = map.x0() - pad * map.res();
  header.y0 = map.y0() - pad * map.res();
  header.name = map.name() + "-padded";
  MapLayers layers;
  const size_t n = static_cast<size_t>(header.nx) * header.ny;
  layers.density.assign(n, density);
  layers.shelter.assign(n, shelter);
  layers.terrain.assign(n, 0.0f);
  layers.nofly.assign(n, nofly ? 1 : 0);
  for (int j = 0; j < header.ny; ++j) {
    for (int i = 0; i < header.nx; ++i) {
      const size_t k = static_cast<size_t>(j) * header.nx + i;
      const int oi = i - pad;
      const int oj = j - pad;
      if (map.Contains(oi, oj)) {
        layers.density[k] = map.density(oi, oj);
        layers.shelter[k] = map.shelter(oi, oj);
        layers.terrain[k] = map.terrain(oi, oj);
        layers.nofly[k] = map.nofly(oi, oj) ? 1 : 0;
      } else {
        layers.terrain[k] = terrain(oi, oj);
      }
    }
  }
  for (const LandingSite& s : map.landing_sites()) {
    layers.landing_sites.push_back({s.name, s.i + pad, s.j + pad});
  }
  auto padded = RiskMap::Create(std::move(header), std::move(layers));
  EXPECT_TRUE(padded.ok()) << padded.status();
  return padded.ok() ? *padded : nullptr;
}

std::shared_ptr<const RiskModel> ModelOf(std::shared_ptr<const RiskMap> map) {
  auto model = RiskModel::Create(std::move(map), ModelParams{});
  EXPECT_TRUE(model.ok()) << model.status();
  return model.ok() ? *model : nullptr;
}

// Every admissibility sample of every piece has its impact window wholly
// inside the map.
void ExpectWindowsInside(const RiskModel& model, const std::vector<Pose>& waypoints) {
  int64_t samples = 0;
  ASSERT_NO_FATAL_FAILURE(testing_planner::ExpectImpactWindowsInside(model, waypoints, &samples));
  EXPECT_GT(samples, 100);
}

// A small demo-city (2 km) whose edges are close to every route.
std::shared_ptr<const RiskMap> SmallCity() {
  DemoCityOptions options;
  options.size_m = 2000.0;
  options.res_m = 5.0;
  auto map = MakeDemoCity(options);
  EXPECT_TRUE(map.ok()) << map.status();
  return map.ok() ? *map : nullptr;
}

TEST(UnknownGroundTest, AdmissibleRiskIsBitIdenticalWhateverLiesOutsideTheMap) {
  auto map = SmallCity();
  ASSERT_NE(map, nullptr);
  auto model = ModelOf(map);
  ASSERT_NE(model, nullptr);
  constexpr int kPad = 80;  // 400 m: more than any window reaches
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> hills(0.0f, 400.0f);
  const auto edge_terrain = [&](int i, int j) {
    return map->terrain(std::clamp(i, 0, map->nx() - 1), std::clamp(j, 0, map->ny() - 1));
  };
  const auto random_terrain = [&](int, int) { return hills(rng); };
  // Empty ground outside (version 1's reading), and a dense crowd without
  // shelter on random hills.
  auto empty = ModelOf(Padded(*map, kPad, 0.0f, 10.0f, edge_terrain, /*nofly=*/true));
  auto crowd = ModelOf(Padded(*map, kPad, 0.2f, 0.0f, random_terrain, /*nofly=*/true));
  ASSERT_NE(empty, nullptr);
  ASSERT_NE(crowd, nullptr);

  // Trajectories that hug the edges: every improvement RISK_RRT_STAR streams
  // between corners of the small city, and straight legs along its edges.
  std::vector<std::vector<Pose>> trajectories;
  const double w = map->width_m();
  const struct {
    double x0, y0, th0, x1, y1, th1;
  } legs[] = {{250, 250, kPi / 2, 250, w - 250, kPi / 2},
              {250, w - 250, 0, w - 250, w - 250, 0},
              {w - 250, w - 250, 1.5 * kPi, w - 250, 250, 1.5 * kPi},
              {w - 300, 300, kPi, 300, 300, kPi}};
  for (const auto& l : legs) {
    auto s = bench::FindFlyablePose(*model, l.x0, l.y0, l.th0);
    auto g = bench::FindFlyablePose(*model, l.x1, l.y1, l.th1);
    ASSERT_TRUE(s && g);
    const auto out = testing_planner::RunPlan(PlannerAlgorithm::kRiskRrtStar, model, *s, *g,
                                              /*iterations=*/1500, /*seed=*/3);
    ASSERT_TRUE(out.result.ok()) << out.result.status();
    for (const PlanImprovement& i : out.improvements) trajectories.push_back(i.waypoints);
  }
  ASSERT_GE(trajectories.size(), 4u);

  int compared = 0;
  for (const std::vector<Pose>& waypoints : trajectories) {
    auto pieces = PiecesFromWaypoints(waypoints, model->params());
    ASSERT_TRUE(pieces.ok());
    auto base = EvaluateTrajectory(*model, *pieces);
    ASSERT_TRUE(base.ok());
    ASSERT_TRUE(base->admissible);
    ASSERT_GT(base->risk, 0.0);
    for (const auto* padded : {&empty, &crowd}) {
      auto eval = EvaluateTrajectory(**padded, *pieces);
      ASSERT_TRUE(eval.ok());
      EXPECT_TRUE(eval->admissible);
      EXPECT_EQ(eval->risk, base->risk);  // bit for bit
      ASSERT_EQ(eval->pieces.size(), base->pieces.size());
      for (size_t k = 0; k < eval->pieces.size(); ++k) {
        EXPECT_EQ(eval->pieces[k].risk, base->pieces[k].risk);
      }
      ++compared;
    }
  }
  EXPECT_EQ(compared, 2 * static_cast<int>(trajectories.size()));

  // The padding is where version 1 found its cheap border: a configuration
  // 20 m inside the west edge heading west has no risk on the map, and one
  // on each padded map that differs between them.
  const Pose border{20.0, 0.5 * w, map->terrain(4, map->ny() / 2) + 60.0, kPi};
  EXPECT_FALSE(model->Evaluate(border).defined);
  EXPECT_EQ(model->CheckConfiguration(border), ViolationKind::kImpactOutsideMap);
  const ConfigurationRisk on_empty = empty->Evaluate(border);
  const ConfigurationRisk on_crowd = crowd->Evaluate(border);
  ASSERT_TRUE(on_empty.defined && on_crowd.defined);
  EXPECT_LT(on_empty.risk, on_crowd.risk);
}

// Every planner's final trajectory on demo-city, on routes along its edges
// where version 1 found empty ground, keeps every impact window inside.
TEST(UnknownGroundTest, EveryPlannersTrajectoryKeepsItsWindowsInsideTheMap) {
  auto model = testing_planner::DemoCityModel();
  ASSERT_NE(model, nullptr);
  const double w = model->map().width_m();
  const struct {
    const char* name;
    double x0, y0, th0, x1, y1, th1;
  } routes[] = {{"west-edge", 350, 1200, kPi / 2, 350, w - 1200, kPi / 2},
                {"north-edge", 1200, w - 350, 0, w - 1200, w - 350, 0},
                {"across", 1200, 1500, kPi / 4, w - 1200, w - 1500, kPi / 4}};
  const struct {
    PlannerAlgorithm algorithm;
    int64_t iterations;
  } planners[] = {{PlannerAlgorithm::kRiskRrtStar, 3000},
                  {PlannerAlgorithm::kRrt, 3000},
                  {PlannerAlgorithm::kGenetic, 60},
                  {PlannerAlgorithm::kHarmonic, 200}};
  int planned = 0;
  for (const auto& r : routes) {
    auto s = bench::FindFlyablePose(*model, r.x0, r.y0, r.th0);
    auto g = bench::FindFlyablePose(*model, r.x1, r.y1, r.th1);
    ASSERT_TRUE(s && g) << r.name;
    for (const auto& p : planners) {
      SCOPED_TRACE(testing::Message() << r.name << " " << PlannerAlgorithmName(p.algorithm));
      const auto out = testing_planner::RunPlan(p.algorithm, model, *s, *g, p.iterations, 11);
      ASSERT_TRUE(out.result.ok()) << out.result.status();
      if (!out.result->best.has_value()) continue;  // no trajectory within the budget
      ExpectWindowsInside(*model, out.result->best->waypoints);
      for (const PlanImprovement& i : out.improvements) ExpectWindowsInside(*model, i.waypoints);
      ++planned;
    }
  }
  // Every planner finds a trajectory on most routes within these budgets.
  EXPECT_GE(planned, 9);
}

}  // namespace
}  // namespace riskplan
