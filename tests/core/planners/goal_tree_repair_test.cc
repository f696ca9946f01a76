// PruneGoalTree (core/planners/goal_tree_repair.h): a goal tree grown on a
// 2 km city, then pruned for the same city with a disc of cells closed (a
// temporary no-fly zone): nothing in the zone survives, every kept edge is
// admissible and exact under the new model, a plan that begins from the
// pruned tree returns EvaluateTrajectory's risk bit for bit, and malformed
// trees are refused.
#include "core/planners/goal_tree_repair.h"

#include <cmath>
#include <memory>
#include <vector>

#include "core/flight/piece_risk.h"
#include "core/flight/trajectory_piece.h"
#include "core/map/demo_city.h"
#include "core/planners/shared_goal_tree.h"
#include "gtest/gtest.h"
#include "tests/core/planner_test_util.h"

namespace riskplan {
namespace {

using testing_planner::FindFlyablePose;
using testing_planner::ReEvaluate;
using testing_planner::WithClosedDisc;

constexpr double kZoneX = 1000.0;
constexpr double kZoneY = 1000.0;
constexpr double kZoneR = 150.0;

struct Grown {
  std::shared_ptr<const RiskModel> model;
  Pose start;
  GoalTree tree;
};

// A tree from a goal in the city's east to a start in its west, grown for
// `iterations` iterations with seed 7.
Grown GrowTree(int64_t iterations) {
  Grown g;
  g.model = testing_planner::SmallCityModel(0.0, 0.0);
  const std::optional<Pose> goal = FindFlyablePose(*g.model, 1700, 1000, 0.0);
  const std::optional<Pose> start = FindFlyablePose(*g.model, 300, 1000, 0.0);
  EXPECT_TRUE(goal.has_value() && start.has_value());
  g.start = *start;
  SharedTreeProblem problem;
  problem.model = g.model;
  problem.goal = *goal;
  SharedTreeMission mission;
  mission.start = *start;
  mission.budget.max_iterations = iterations;
  problem.missions.push_back(mission);
  SharedTreeOptions options;
  options.seed = 7;
  CancellationToken cancel;
  SharedGoalTreePlanner planner;
  auto results = planner.Plan(problem, options, cancel, nullptr, nullptr, &g.tree);
  EXPECT_TRUE(results.ok()) << results.status();
  EXPECT_GT(g.tree.nodes.size(), static_cast<size_t>(iterations / 2));
  return g;
}

// Every node of `tree` is admissible under `model`, and so is every midpoint
// of its edge to its parent; returns the samples checked.
int64_t ExpectEveryEdgeAdmissible(const GoalTree& tree, const RiskModel& model) {
  const ModelParams& mp = model.params();
  int64_t samples = 0;
  for (const GoalTreeNode& node : tree.nodes) {
    EXPECT_EQ(model.CheckConfiguration(node.pose), ViolationKind::kNone);
    if (node.parent < 0) continue;
    const PieceRisk rule(TrajectoryPiece::Manoeuvre(node.pose, tree.nodes[node.parent].pose,
                                                    mp.GroundTurnRadius(), mp.GroundClimbAngle()),
                         mp.sample_step_m, mp);
    for (int64_t i = 0; i < rule.parts(); ++i, ++samples) {
      EXPECT_EQ(model.CheckConfiguration(rule.Midpoint(i)), ViolationKind::kNone);
    }
  }
  return samples;
}

TEST(GoalTreeRepairTest, AnUnchangedModelKeepsEveryNode) {
  const Grown g = GrowTree(500);
  GoalTreePruneStats stats;
  auto pruned = PruneGoalTree(g.tree, *g.model, {}, &stats);
  ASSERT_TRUE(pruned.ok()) << pruned.status();
  ASSERT_EQ(pruned->nodes.size(), g.tree.nodes.size());
  EXPECT_EQ(stats.kept, static_cast<int64_t>(g.tree.nodes.size()));
  EXPECT_EQ(stats.cut_edges, 0);
  EXPECT_EQ(stats.orphaned, 0);
  EXPECT_GT(stats.checked_samples, stats.kept);
  for (size_t k = 0; k < g.tree.nodes.size(); ++k) {
    EXPECT_EQ(pruned->nodes[k].parent, g.tree.nodes[k].parent);
    EXPECT_EQ(pruned->nodes[k].cost, g.tree.nodes[k].cost);
    EXPECT_EQ(pruned->nodes[k].edge_risk, g.tree.nodes[k].edge_risk);
  }
  EXPECT_EQ(pruned->generation, g.tree.generation);
  EXPECT_EQ(pruned->seed, g.tree.seed);
}

TEST(GoalTreeRepairTest, AClosedDiscCutsTheEdgesThroughItAndTheirSubtrees) {
  const Grown g = GrowTree(500);
  const std::shared_ptr<const RiskModel> zoned = WithClosedDisc(*g.model, kZoneX, kZoneY, kZoneR);
  GoalTreePruneStats stats;
  auto pruned = PruneGoalTree(g.tree, *zoned, {}, &stats);
  ASSERT_TRUE(pruned.ok()) << pruned.status();
  const int64_t n = static_cast<int64_t>(g.tree.nodes.size());
  EXPECT_EQ(stats.kept + stats.cut_edges + stats.orphaned, n);
  EXPECT_GT(stats.cut_edges, 0);  // the tree spans the city: some edges crossed the disc
  EXPECT_GT(stats.kept, n / 2);   // ... but most of it lies elsewhere
  ASSERT_EQ(static_cast<int64_t>(pruned->nodes.size()), stats.kept);
  // Nothing in the zone, every kept edge admissible under the new model.
  for (const GoalTreeNode& node : pruned->nodes) {
    EXPECT_GT(std::hypot(node.pose.x - kZoneX, node.pose.y - kZoneY), kZoneR);
  }
  EXPECT_GT(ExpectEveryEdgeAdmissible(*pruned, *zoned), 1000);
  // The kept nodes are the tree's own, in order, with their risks: each one
  // of the original nodes with the same pose, cost and edge risk, and its
  // parent the renumbered original parent.
  std::vector<int64_t> original_of;
  for (size_t k = 0, m = 0; k < g.tree.nodes.size() && m < pruned->nodes.size(); ++k) {
    const GoalTreeNode& a = g.tree.nodes[k];
    const GoalTreeNode& b = pruned->nodes[m];
    if (a.pose.x == b.pose.x && a.pose.y == b.pose.y && a.pose.z == b.pose.z &&
        a.pose.theta == b.pose.theta) {
      EXPECT_EQ(a.cost, b.cost);
      EXPECT_EQ(a.edge_risk, b.edge_risk);
      original_of.push_back(static_cast<int64_t>(k));
      ++m;
    }
  }
  ASSERT_EQ(original_of.size(), pruned->nodes.size());
  for (size_t m = 1; m < pruned->nodes.size(); ++m) {
    ASSERT_GE(pruned->nodes[m].parent, 0);
    EXPECT_EQ(original_of[pruned->nodes[m].parent], g.tree.nodes[original_of[m]].parent);
  }
  EXPECT_EQ(pruned->nodes[0].parent, -1);
}

TEST(GoalTreeRepairTest, CheckingOnlyWhereTheModelIsStricterCutsTheSame) {
  const Grown g = GrowTree(500);
  const std::shared_ptr<const RiskModel> zoned = WithClosedDisc(*g.model, kZoneX, kZoneY, kZoneR);
  const std::optional<PruneRegion> region = StricterRegion(*g.model, *zoned);
  ASSERT_TRUE(region.has_value());
  // The disc's cells, and the cells whose glide altitude rose around it.
  EXPECT_LE(region->x_min, kZoneX - kZoneR + 5.0);
  EXPECT_GE(region->x_max, kZoneX + kZoneR - 5.0);
  EXPECT_LE(region->y_min, kZoneY - kZoneR + 5.0);
  EXPECT_GE(region->y_max, kZoneY + kZoneR - 5.0);
  GoalTreePruneStats full_stats, region_stats;
  auto full = PruneGoalTree(g.tree, *zoned, {}, &full_stats);
  auto limited = PruneGoalTree(g.tree, *zoned, {}, &region_stats, region);
  ASSERT_TRUE(full.ok() && limited.ok());
  ASSERT_EQ(full->nodes.size(), limited->nodes.size());
  for (size_t k = 0; k < full->nodes.size(); ++k) {
    EXPECT_EQ(full->nodes[k].parent, limited->nodes[k].parent);
    EXPECT_EQ(full->nodes[k].pose.x, limited->nodes[k].pose.x);
  }
  EXPECT_EQ(full_stats.cut_edges, region_stats.cut_edges);
  EXPECT_GT(region_stats.skipped_edges, 0);
  EXPECT_LT(region_stats.checked_samples, full_stats.checked_samples);
  // Nowhere stricter: the same model, or one with fewer closed cells.
  EXPECT_FALSE(StricterRegion(*g.model, *g.model).has_value());
  EXPECT_FALSE(StricterRegion(*zoned, *g.model).has_value());
}

TEST(GoalTreeRepairTest, APlanFromThePrunedTreeIsAdmissibleAndExact) {
  const Grown g = GrowTree(500);
  const std::shared_ptr<const RiskModel> zoned = WithClosedDisc(*g.model, kZoneX, kZoneY, kZoneR);
  auto pruned = PruneGoalTree(g.tree, *zoned);
  ASSERT_TRUE(pruned.ok()) << pruned.status();
  SharedTreeProblem problem;
  problem.model = zoned;
  problem.goal = g.tree.goal;
  SharedTreeMission mission;
  mission.start = g.start;
  mission.budget.max_iterations = 300;
  problem.missions.push_back(mission);
  SharedTreeOptions options;
  options.seed = 7;
  options.initial_tree = std::make_shared<const GoalTree>(*pruned);
  CancellationToken cancel;
  SharedGoalTreePlanner planner;
  GoalTree grown;
  auto results = planner.Plan(problem, options, cancel, nullptr, nullptr, &grown);
  ASSERT_TRUE(results.ok()) << results.status();
  ASSERT_EQ(results->size(), 1u);
  ASSERT_TRUE((*results)[0].ok()) << (*results)[0].status();
  ASSERT_TRUE((*results)[0]->best.has_value());
  bool admissible = false;
  const double risk = ReEvaluate(*zoned, (*results)[0]->best->waypoints, &admissible);
  EXPECT_TRUE(admissible);
  EXPECT_EQ((*results)[0]->best->risk, risk);
  // The tree grew on from the pruned one.
  EXPECT_GT(grown.nodes.size(), pruned->nodes.size());
  EXPECT_EQ(grown.generation, pruned->generation + 1);
}

TEST(GoalTreeRepairTest, AClosedGoalLeavesNothing) {
  const Grown g = GrowTree(200);
  const std::shared_ptr<const RiskModel> zoned =
      WithClosedDisc(*g.model, g.tree.goal.x, g.tree.goal.y, 60.0);
  auto pruned = PruneGoalTree(g.tree, *zoned);
  ASSERT_TRUE(pruned.ok()) << pruned.status();
  EXPECT_TRUE(pruned->nodes.empty());
}

TEST(GoalTreeRepairTest, RefusesWhatIsNotATree) {
  const Grown g = GrowTree(100);
  GoalTree cycle = g.tree;
  ASSERT_GT(cycle.nodes.size(), 3u);
  cycle.nodes[1].parent = 2;
  cycle.nodes[2].parent = 1;
  auto r = PruneGoalTree(cycle, *g.model);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(r.status().message().find("cycle"), std::string_view::npos) << r.status();
  GoalTree dangling = g.tree;
  dangling.nodes[1].parent = static_cast<int32_t>(dangling.nodes.size());
  r = PruneGoalTree(dangling, *g.model);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(r.status().message().find("node 1 has parent"), std::string_view::npos) << r.status();
  GoalTree rooted_elsewhere = g.tree;
  rooted_elsewhere.nodes[0].parent = 1;
  r = PruneGoalTree(rooted_elsewhere, *g.model);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  CancellationToken cancelled;
  cancelled.Cancel();
  r = PruneGoalTree(g.tree, *g.model, StopCondition(&cancelled));
  EXPECT_EQ(r.status().code(), absl::StatusCode::kCancelled);
}

}  // namespace
}  // namespace riskplan
