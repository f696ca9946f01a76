// The guide of RISK_RRT_STAR (core/planners/cost_to_go_field.h and the
// planner's parameter `guide`): the field cache honours its bounds, the
// guided planner is deterministic for a seed and an iteration budget and
// reports EvaluateTrajectory's risk bit for bit (still air and wind), and
// `guide` = 0 is the planner without the parameter.
#include "core/planners/cost_to_go_field.h"

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/planners/shared_goal_tree.h"
#include "gtest/gtest.h"
#include "tests/core/planner_test_util.h"

namespace riskplan {
namespace {

using testing_planner::FindFlyablePose;
using testing_planner::ReEvaluate;

// The 2 km city, the wind (if any) from 300°.
std::shared_ptr<const RiskModel> SmallCity(double wind_mps) {
  return testing_planner::SmallCityModel(wind_mps, 300.0);
}

TEST(GuideFieldCacheTest, HonoursItsByteAndEntryBounds) {
  auto model = SmallCity(0.0);
  DirectRiskEvaluator evaluator;
  const LatticeOptions options = GuideLatticeOptions(250.0, 25.0);
  auto one =
      CostToGoField::Build(*model, *FindFlyablePose(*model, 1000, 1000, 0), options, &evaluator);
  ASSERT_TRUE(one.ok()) << one.status();
  const size_t bytes = (*one)->MemoryBytes();
  ASSERT_GT(bytes, 0u);
  // Room for two and a half fields.
  GuideFieldCache cache({bytes * 5 / 2, 100});
  const double goals[][2] = {{500, 500}, {1500, 500}, {500, 1500}, {1500, 1500}, {1000, 1000}};
  for (const auto& xy : goals) {
    auto goal = FindFlyablePose(*model, xy[0], xy[1], 0.0);
    ASSERT_TRUE(goal.has_value());
    auto field = cache.Get(*model, *goal, options, &evaluator);
    ASSERT_TRUE(field.ok()) << field.status();
    EXPECT_LE(cache.stats().bytes, cache.limits().max_bytes);
    EXPECT_LE(cache.stats().entries, 2u);
  }
  EXPECT_GE(cache.stats().evictions, 3u);
  // A hit for the last goal; the first was evicted.
  const uint64_t misses = cache.stats().misses;
  ASSERT_TRUE(
      cache.Get(*model, *FindFlyablePose(*model, 1000, 1000, 0.0), options, &evaluator).ok());
  EXPECT_EQ(cache.stats().misses, misses);
  // The entry bound.
  GuideFieldCache two({size_t{1} << 30, 2});
  for (const auto& xy : goals) {
    ASSERT_TRUE(
        two.Get(*model, *FindFlyablePose(*model, xy[0], xy[1], 0.0), options, &evaluator).ok());
    EXPECT_LE(two.stats().entries, 2u);
  }
}

struct Outcome {
  double risk = -1.0;
  std::vector<Pose> waypoints;
  int64_t tree = 0;
};

Outcome Plan(const std::shared_ptr<const RiskModel>& model, const Pose& s, const Pose& g,
             const std::map<std::string, double>& params) {
  auto planner = MakePlanner(PlannerAlgorithm::kRiskRrtStar);
  EXPECT_TRUE(planner.ok());
  PlanOptions options;
  options.budget.max_time_s = 0.0;
  options.budget.max_iterations = 200;
  options.seed = 11;
  options.params = params;
  CancellationToken cancel;
  auto result = (*planner)->Plan({model, s, g}, options, cancel, nullptr);
  EXPECT_TRUE(result.ok()) << result.status();
  Outcome out;
  if (result.ok() && result->best.has_value()) {
    out.risk = result->best->risk;
    out.waypoints = result->best->waypoints;
    out.tree = result->tree_size;
  }
  return out;
}

TEST(GuidedPlannerTest, DeterministicAndExact) {
  for (double wind : {0.0, 8.0}) {
    SCOPED_TRACE(wind);
    auto model = SmallCity(wind);
    const Pose s = *FindFlyablePose(*model, 300, 400, 0.5);
    const Pose g = *FindFlyablePose(*model, 1700, 1600, 0.5);
    const std::map<std::string, double> guided = {{"guide", 1.0}, {"guide_field_m", 200.0}};
    const Outcome a = Plan(model, s, g, guided);
    const Outcome b = Plan(model, s, g, guided);
    ASSERT_GT(a.risk, 0.0);
    EXPECT_EQ(a.risk, b.risk);
    EXPECT_EQ(a.tree, b.tree);
    ASSERT_EQ(a.waypoints.size(), b.waypoints.size());
    for (size_t k = 0; k < a.waypoints.size(); ++k) {
      EXPECT_EQ(a.waypoints[k].x, b.waypoints[k].x);
      EXPECT_EQ(a.waypoints[k].theta, b.waypoints[k].theta);
    }
    bool admissible = false;
    EXPECT_EQ(ReEvaluate(*model, a.waypoints, &admissible), a.risk);
    EXPECT_TRUE(admissible);
  }
}

TEST(GuidedPlannerTest, GuideZeroIsThePlannerWithoutIt) {
  auto model = SmallCity(0.0);
  const Pose s = *FindFlyablePose(*model, 300, 1000, 0.0);
  const Pose g = *FindFlyablePose(*model, 1700, 1000, 0.0);
  const Outcome plain = Plan(model, s, g, {});
  const Outcome zero = Plan(model, s, g, {{"guide", 0.0}, {"guide_field_m", 300.0}});
  EXPECT_EQ(plain.risk, zero.risk);
  EXPECT_EQ(plain.tree, zero.tree);
  ASSERT_EQ(plain.waypoints.size(), zero.waypoints.size());
}

TEST(GuidedPlannerTest, SharedGoalTreeMissionsUseOneField) {
  auto model = SmallCity(0.0);
  const Pose goal = *FindFlyablePose(*model, 1000, 1000, 0.0);
  const size_t misses_before = GuideFieldCache::Default().stats().misses;
  const std::map<std::string, double> guided = {{"guide", 1.0}, {"guide_field_m", 250.0}};
  for (const auto& xy : {std::pair{300.0, 300.0}, std::pair{1700.0, 300.0}}) {
    const Outcome o = Plan(model, *FindFlyablePose(*model, xy.first, xy.second, 0.0), goal, guided);
    bool admissible = false;
    EXPECT_EQ(ReEvaluate(*model, o.waypoints, &admissible), o.risk);
    EXPECT_TRUE(admissible);
  }
  // Two plans to one goal: one field built.
  EXPECT_EQ(GuideFieldCache::Default().stats().misses, misses_before + 1);
}

}  // namespace
}  // namespace riskplan
