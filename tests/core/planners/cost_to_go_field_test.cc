// The guide of RISK_RRT_STAR (core/planners/cost_to_go_field.h and the
// planner's parameter `guide`): the field cache honours its bounds, the
// guided planner is deterministic for a seed and an iteration budget and
// reports EvaluateTrajectory's risk bit for bit (still air and wind), and
// `guide` = 0 is the planner without the parameter; the field's least
// cost-to-go near a point, which the informed draws (`guide_informed`) read.
#include "core/planners/cost_to_go_field.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <thread>
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

TEST(CostToGoFieldTest, LeastCostNearIsTheLeastOfItsPosition) {
  auto model = SmallCity(0.0);
  DirectRiskEvaluator evaluator;
  const LatticeOptions options = GuideLatticeOptions(250.0, 25.0);
  auto field =
      CostToGoField::Build(*model, *FindFlyablePose(*model, 1000, 1000, 0), options, &evaluator);
  ASSERT_TRUE(field.ok()) << field.status();
  const StateLattice& g = (*field)->lattice();
  const int per = g.states_per_position();
  int finite = 0;
  for (int32_t s = 0; s < g.state_count(); s += per) {
    if (!g.valid(s)) continue;
    const Pose& p = g.pose(s);
    double least = std::numeric_limits<double>::infinity();
    for (int32_t t = s - s % per; t < s - s % per + per; ++t) {
      if (g.valid(t)) least = std::min(least, (*field)->field().cost[t]);
    }
    // The state's own position, and a point 100 m off the centre in its square.
    EXPECT_EQ((*field)->LeastCostNear(p.x, p.y), least);
    EXPECT_EQ((*field)->LeastCostNear(p.x + 100.0, p.y - 100.0), least);
    if (least < std::numeric_limits<double>::infinity()) ++finite;
  }
  EXPECT_GT(finite, 10);
  const RiskMap& map = model->map();
  EXPECT_EQ((*field)->LeastCostNear(map.x0() - 1.0, map.y0() + 10.0),
            std::numeric_limits<double>::infinity());
}

TEST(CostToGoFieldTest, LevelsAndHeadingsOfTheGuideLattice) {
  const LatticeOptions one = GuideLatticeOptions(400.0, 25.0);
  EXPECT_EQ(one.headings, 8);
  EXPECT_EQ(one.level_offsets_m, std::vector<double>{5.0});
  const LatticeOptions four = GuideLatticeOptions(200.0, 25.0, 16, 4);
  EXPECT_EQ(four.headings, 16);
  ASSERT_EQ(four.level_offsets_m.size(), 4u);
  EXPECT_EQ(four.level_offsets_m.front(), 5.0);
  EXPECT_EQ(four.level_offsets_m.back(), 120.0);
  EXPECT_NEAR(four.level_offsets_m[1], 5.0 + 115.0 / 3.0, 1e-12);
  EXPECT_TRUE(CheckLatticeOptions(four).ok());

  // Fields of one goal that differ only in their levels are two entries.
  auto model = SmallCity(0.0);
  DirectRiskEvaluator evaluator;
  GuideFieldCache cache({size_t{1} << 30, 8});
  const Pose goal = *FindFlyablePose(*model, 1000, 1000, 0.0);
  auto a = cache.Get(*model, goal, GuideLatticeOptions(250.0, 25.0, 8, 1), &evaluator);
  auto b = cache.Get(*model, goal, GuideLatticeOptions(250.0, 25.0, 8, 3), &evaluator);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(cache.stats().entries, 2u);
  EXPECT_EQ((*b)->lattice().states_per_position(), 8 * 3);
  // More levels: no state's cost-to-go is higher than with the lowest alone
  // (every route of the one-level lattice is one of the three-level one's).
  EXPECT_LE((*b)->LeastCostNear(300.0, 300.0), (*a)->LeastCostNear(300.0, 300.0));
}

struct Outcome {
  double risk = -1.0;
  std::vector<Pose> waypoints;
  int64_t tree = 0;
  std::vector<TreeEdge> edges;  // with record_tree
};

Outcome Plan(const std::shared_ptr<const RiskModel>& model, const Pose& s, const Pose& g,
             const std::map<std::string, double>& params, bool record_tree = false) {
  auto planner = MakePlanner(PlannerAlgorithm::kRiskRrtStar);
  EXPECT_TRUE(planner.ok());
  PlanOptions options;
  options.budget.max_time_s = 0.0;
  options.budget.max_iterations = 200;
  options.seed = 11;
  options.params = params;
  options.record_tree = record_tree;
  CancellationToken cancel;
  auto result = (*planner)->Plan({model, s, g}, options, cancel, nullptr);
  EXPECT_TRUE(result.ok()) << result.status();
  Outcome out;
  if (result.ok() && result->best.has_value()) {
    out.risk = result->best->risk;
    out.waypoints = result->best->waypoints;
    out.tree = result->tree_size;
    out.edges = result->tree;
  }
  return out;
}

// Plans twice with the same seed and iteration budget: the same result bit
// for bit, admissible, its risk EvaluateTrajectory's. Returns the first.
Outcome PlanTwiceAndCheck(const std::shared_ptr<const RiskModel>& model, const Pose& s,
                          const Pose& g, const std::map<std::string, double>& params,
                          bool record_tree = false) {
  const Outcome a = Plan(model, s, g, params, record_tree);
  const Outcome b = Plan(model, s, g, params);
  EXPECT_GT(a.risk, 0.0);
  EXPECT_EQ(a.risk, b.risk);
  EXPECT_EQ(a.tree, b.tree);
  EXPECT_EQ(a.waypoints.size(), b.waypoints.size());
  for (size_t k = 0; k < std::min(a.waypoints.size(), b.waypoints.size()); ++k) {
    EXPECT_EQ(a.waypoints[k].x, b.waypoints[k].x);
    EXPECT_EQ(a.waypoints[k].theta, b.waypoints[k].theta);
  }
  bool admissible = false;
  EXPECT_EQ(ReEvaluate(*model, a.waypoints, &admissible), a.risk);
  EXPECT_TRUE(admissible);
  return a;
}

TEST(GuidedPlannerTest, DeterministicAndExact) {
  for (double wind : {0.0, 8.0}) {
    SCOPED_TRACE(wind);
    auto model = SmallCity(wind);
    const Pose s = *FindFlyablePose(*model, 300, 400, 0.5);
    const Pose g = *FindFlyablePose(*model, 1700, 1600, 0.5);
    const std::map<std::string, double> guided = {{"guide", 1.0},
                                                  {"guide_field_m", 200.0},
                                                  {"guide_field_headings", wind > 0.0 ? 16.0 : 8.0},
                                                  {"guide_field_levels", wind > 0.0 ? 3.0 : 1.0}};
    PlanTwiceAndCheck(model, s, g, guided);
  }
}

TEST(GuidedPlannerTest, InformedSamplingIsDeterministicExactAndChangesTheSearch) {
  for (double wind : {0.0, 8.0}) {
    SCOPED_TRACE(wind);
    auto model = SmallCity(wind);
    // The goal near one corner: much of the map costs more to the goal than
    // the start does, so the informed draws reject samples.
    const Pose s = *FindFlyablePose(*model, 1000, 900, 0.5);
    const Pose g = *FindFlyablePose(*model, 300, 300, 0.5);
    const std::map<std::string, double> informed = {
        {"guide", 1.0}, {"guide_field_m", 200.0}, {"guide_informed", 1.0}};
    const Outcome a = PlanTwiceAndCheck(model, s, g, informed, /*record_tree=*/true);
    ASSERT_GT(a.risk, 0.0);
    // In still air: the same plan without the informed draws grows another
    // tree, and the informed one's nodes lie nearer the goal (the field's
    // cost-to-go). (In this wind the 200-m field has no route from this
    // start, so the draws are off and the trees are the same.)
    if (wind != 0.0) continue;
    const Outcome plain =
        Plan(model, s, g, {{"guide", 1.0}, {"guide_field_m", 200.0}}, /*record_tree=*/true);
    ASSERT_GT(plain.risk, 0.0);
    auto mean_distance = [&](const Outcome& o) {
      double sum = 0.0;
      for (const TreeEdge& e : o.edges) sum += std::hypot(e.from.x - g.x, e.from.y - g.y);
      return sum / static_cast<double>(std::max<size_t>(1, o.edges.size()));
    };
    ASSERT_FALSE(a.edges.empty());
    EXPECT_LT(mean_distance(a), mean_distance(plain));
  }
}

// The direct evaluator, 10 ms slower per batch.
class SlowEvaluator final : public RiskEvaluator {
 public:
  absl::Status EvaluateBatch(const RiskModel& model, std::span<const Pose> configs,
                             std::span<ConfigurationRisk> out) override {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    return direct_.EvaluateBatch(model, configs, out);
  }
  uint64_t evaluated() const override { return direct_.evaluated(); }

 private:
  DirectRiskEvaluator direct_;
};

TEST(GuidedPlannerTest, AFieldTooSlowForTheBudgetIsGivenUpAndThePlanGoesOn) {
  // A field of a spacing no other test uses (not cached), whose build takes
  // far more than half of a 1-s budget at 10 ms a batch: the run gives it up
  // at half the budget, keeps nothing in the cache, and plans on without it
  // (no coarse guide route either, so every node is the iterations').
  auto model = SmallCity(0.0);
  SlowEvaluator slow;
  auto planner = MakePlanner(PlannerAlgorithm::kRiskRrtStar, &slow);
  ASSERT_TRUE(planner.ok());
  PlanOptions options;
  options.budget.max_time_s = 1.0;
  options.seed = 3;
  options.params = {{"guide", 1.0}, {"guide_field_m", 130.0}, {"guide_cell_m", 0.0}};
  const size_t entries = GuideFieldCache::Default().stats().entries;
  CancellationToken cancel;
  auto result = (*planner)->Plan(
      {model, *FindFlyablePose(*model, 300, 1000, 0.0), *FindFlyablePose(*model, 1700, 1000, 0.0)},
      options, cancel, nullptr);
  ASSERT_TRUE(result.ok()) << result.status();
  EXPECT_GT(result->iterations, 0);
  EXPECT_EQ(GuideFieldCache::Default().stats().entries, entries);
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
