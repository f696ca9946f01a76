// A shared goal tree exported at the end of a plan and begun from by the
// next one (GoalTree, SharedTreeOptions::initial_tree): what a cache of goal
// trees (server/models/goal_tree_cache.h) relies on.
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/planners/shared_goal_tree.h"
#include "gtest/gtest.h"
#include "tests/core/planner_test_util.h"

namespace riskplan {
namespace {

using testing_planner::FindFlyablePose;
using testing_planner::ReEvaluate;

struct Outcome {
  absl::StatusOr<std::vector<absl::StatusOr<PlanResult>>> results;
  std::vector<std::pair<size_t, PlanImprovement>> improvements;
  GoalTree grown;
};

class GoalTreeReuseTest : public testing_planner::DemoCityPlannerTest {
 protected:
  static void SetUpTestSuite() {
    DemoCityPlannerTest::SetUpTestSuite();
    depot_ = *FindFlyablePose(*model_, 6500, 1500, kPi / 2);
    other_goal_ = *FindFlyablePose(*model_, 1500, 6000, 0.0);
    const double spots[][3] = {
        {1200, 6500, 0.0}, {1500, 2500, 0.5}, {4000, 7000, 4.7}, {7000, 6500, 4.0}};
    for (const auto& s : spots) starts_.push_back(*FindFlyablePose(*model_, s[0], s[1], s[2]));
  }

  static SharedTreeProblem Problem(const Pose& goal, const std::vector<size_t>& which,
                                   int64_t iterations) {
    SharedTreeProblem p;
    p.model = model_;
    p.goal = goal;
    for (size_t k : which) {
      SharedTreeMission m;
      m.start = starts_[k];
      m.budget.max_time_s = 0.0;
      m.budget.max_iterations = iterations;
      p.missions.push_back(m);
    }
    return p;
  }

  static Outcome Plan(const SharedTreeProblem& problem, uint64_t seed,
                      std::shared_ptr<const GoalTree> initial, bool export_tree = true,
                      std::map<std::string, double> params = {}) {
    Outcome out;
    SharedTreeOptions options;
    options.seed = seed;
    options.params = std::move(params);
    options.initial_tree = std::move(initial);
    CancellationToken token;
    SharedGoalTreePlanner planner;
    out.results = planner.Plan(
        problem, options, token,
        [&](size_t m, const PlanImprovement& i) {
          out.improvements.push_back({m, i});
        },
        nullptr, export_tree ? &out.grown : nullptr);
    return out;
  }

  // Every improvement and result is exactly EvaluateTrajectory's risk of
  // its waypoints, and flies from its mission's start to the goal.
  static void ExpectExactRisks(const SharedTreeProblem& problem, const Outcome& out) {
    ASSERT_TRUE(out.results.ok()) << out.results.status();
    for (const auto& [m, i] : out.improvements) {
      bool admissible = false;
      EXPECT_EQ(i.risk, ReEvaluate(*model_, i.waypoints, &admissible));
      EXPECT_TRUE(admissible);
      EXPECT_EQ(i.waypoints.front().x, problem.missions[m].start.x);
      EXPECT_EQ(i.waypoints.back().x, problem.goal.x);
    }
    for (size_t m = 0; m < problem.missions.size(); ++m) {
      const absl::StatusOr<PlanResult>& r = (*out.results)[m];
      ASSERT_TRUE(r.ok()) << r.status();
      ASSERT_TRUE(r->best.has_value());
      bool admissible = false;
      EXPECT_EQ(r->best->risk, ReEvaluate(*model_, r->best->waypoints, &admissible));
      EXPECT_TRUE(admissible);
    }
  }

  inline static Pose depot_;
  inline static Pose other_goal_;
  inline static std::vector<Pose> starts_;
};

TEST_F(GoalTreeReuseTest, TheExportedTreeIsTheTreeWithoutItsStarts) {
  const SharedTreeProblem problem = Problem(depot_, {0, 1, 2}, 300);
  const Outcome out = Plan(problem, 7, nullptr);
  ASSERT_TRUE(out.results.ok()) << out.results.status();
  const GoalTree& tree = out.grown;
  ASSERT_TRUE((*out.results)[0].ok());
  EXPECT_EQ(static_cast<int64_t>(tree.nodes.size()),
            (*out.results)[0]->tree_size - static_cast<int64_t>(problem.missions.size()));
  EXPECT_EQ(tree.generation, 1);
  EXPECT_EQ(tree.seed, 7u);
  EXPECT_EQ(tree.goal.x, depot_.x);
  ASSERT_FALSE(tree.nodes.empty());
  EXPECT_EQ(tree.nodes[0].parent, -1);
  EXPECT_EQ(tree.nodes[0].cost, 0.0);
  for (size_t i = 1; i < tree.nodes.size(); ++i) {
    const GoalTreeNode& n = tree.nodes[i];
    ASSERT_GE(n.parent, 0);
    ASSERT_LT(static_cast<size_t>(n.parent), tree.nodes.size());
    // R(node) is R(parent) plus its edge's risk (up to the order of additions).
    EXPECT_NEAR(n.cost, tree.nodes[n.parent].cost + n.edge_risk, 1e-9 * (1.0 + n.cost));
  }
}

// Exporting the tree changes nothing about the plan itself.
TEST_F(GoalTreeReuseTest, ExportingLeavesThePlanBitForBit) {
  const SharedTreeProblem problem = Problem(depot_, {0, 3}, 250);
  const Outcome with = Plan(problem, 5, nullptr, /*export_tree=*/true);
  const Outcome without = Plan(problem, 5, nullptr, /*export_tree=*/false);
  ASSERT_TRUE(with.results.ok() && without.results.ok());
  ASSERT_EQ(with.improvements.size(), without.improvements.size());
  for (size_t m = 0; m < problem.missions.size(); ++m) {
    ASSERT_TRUE((*with.results)[m].ok() && (*without.results)[m].ok());
    ASSERT_TRUE((*with.results)[m]->best.has_value());
    EXPECT_EQ((*with.results)[m]->best->risk, (*without.results)[m]->best->risk);
    EXPECT_EQ((*with.results)[m]->tree_size, (*without.results)[m]->tree_size);
  }
}

TEST_F(GoalTreeReuseTest, APlanFromATreeReportsExactRisksAndGrowsIt) {
  const SharedTreeProblem first = Problem(depot_, {0, 1, 2}, 300);
  Outcome a = Plan(first, 11, nullptr);
  ExpectExactRisks(first, a);
  auto tree = std::make_shared<const GoalTree>(std::move(a.grown));

  // Other missions to the same depot: one new start, two known.
  const SharedTreeProblem second = Problem(depot_, {3, 0, 1}, 200);
  const Outcome b = Plan(second, 11, tree);
  ExpectExactRisks(second, b);
  EXPECT_EQ(b.grown.generation, 2);
  EXPECT_GT(b.grown.nodes.size(), tree->nodes.size());
  // It began from the whole tree: its size counts the tree's nodes.
  ASSERT_TRUE((*b.results)[0].ok());
  EXPECT_GE((*b.results)[0]->tree_size,
            static_cast<int64_t>(tree->nodes.size() + second.missions.size()));
  // The tree given was not changed.
  EXPECT_EQ(tree->generation, 1);
}

TEST_F(GoalTreeReuseTest, TheSameTreeAndSeedGiveTheSameResultsBitForBit) {
  const SharedTreeProblem first = Problem(depot_, {0, 1}, 250);
  Outcome a = Plan(first, 3, nullptr);
  ASSERT_TRUE(a.results.ok());
  auto tree = std::make_shared<const GoalTree>(std::move(a.grown));
  const SharedTreeProblem second = Problem(depot_, {2, 3}, 200);
  const Outcome b = Plan(second, 3, tree);
  const Outcome c = Plan(second, 3, tree);
  ExpectExactRisks(second, b);
  ASSERT_TRUE(c.results.ok());
  ASSERT_EQ(b.improvements.size(), c.improvements.size());
  for (size_t k = 0; k < b.improvements.size(); ++k) {
    EXPECT_EQ(b.improvements[k].first, c.improvements[k].first);
    EXPECT_EQ(b.improvements[k].second.risk, c.improvements[k].second.risk);
  }
  for (size_t m = 0; m < second.missions.size(); ++m) {
    const auto& rb = (*b.results)[m];
    const auto& rc = (*c.results)[m];
    ASSERT_TRUE(rb.ok() && rc.ok());
    EXPECT_EQ(rb->best->risk, rc->best->risk);
    EXPECT_EQ(rb->tree_size, rc->tree_size);
    ASSERT_EQ(rb->best->waypoints.size(), rc->best->waypoints.size());
    for (size_t i = 0; i < rb->best->waypoints.size(); ++i) {
      EXPECT_EQ(rb->best->waypoints[i].x, rc->best->waypoints[i].x);
      EXPECT_EQ(rb->best->waypoints[i].y, rc->best->waypoints[i].y);
      EXPECT_EQ(rb->best->waypoints[i].z, rc->best->waypoints[i].z);
      EXPECT_EQ(rb->best->waypoints[i].theta, rc->best->waypoints[i].theta);
    }
  }
  EXPECT_EQ(b.grown.nodes.size(), c.grown.nodes.size());
}

// A tree at max_nodes still answers: each start is connected to it before
// the bound ends the plan, and no exported tree exceeds the bound.
TEST_F(GoalTreeReuseTest, AFullTreeStillAnswersEveryMission) {
  const std::map<std::string, double> params = {{"max_nodes", 250}};
  const SharedTreeProblem problem = Problem(depot_, {0, 1}, 5000);
  Outcome a = Plan(problem, 13, nullptr, true, params);
  ExpectExactRisks(problem, a);
  ASSERT_FALSE(a.grown.nodes.empty());
  EXPECT_LE(a.grown.nodes.size(), 250u);
  auto tree = std::make_shared<const GoalTree>(std::move(a.grown));
  const Outcome b = Plan(problem, 13, tree, true, params);
  ExpectExactRisks(problem, b);
  for (const absl::StatusOr<PlanResult>& r : *b.results) {
    ASSERT_TRUE(r.ok());
    EXPECT_EQ(r->reason, StopReason::kBudgetExhausted);
    EXPECT_LT(r->iterations, 5000);
  }
}

// A tree grown for another goal, other parameters or another seed is refused
// before any mission is planned: it is never used.
TEST_F(GoalTreeReuseTest, ATreeForAnotherGoalParametersOrSeedIsNotUsed) {
  Outcome a = Plan(Problem(depot_, {0}, 150), 9, nullptr);
  ASSERT_TRUE(a.results.ok());
  auto tree = std::make_shared<const GoalTree>(std::move(a.grown));

  const Outcome elsewhere = Plan(Problem(other_goal_, {0}, 100), 9, tree);
  ASSERT_FALSE(elsewhere.results.ok());
  EXPECT_EQ(elsewhere.results.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(elsewhere.results.status().message().find("initial_tree"), std::string::npos);
  EXPECT_TRUE(elsewhere.improvements.empty());
  EXPECT_TRUE(elsewhere.grown.nodes.empty());

  const Outcome reseeded = Plan(Problem(depot_, {0}, 100), 10, tree);
  EXPECT_EQ(reseeded.results.status().code(), absl::StatusCode::kInvalidArgument);

  SharedTreeOptions options;
  options.seed = 9;
  options.params = {{"k_near", 6}};
  options.initial_tree = tree;
  CancellationToken token;
  SharedGoalTreePlanner planner;
  EXPECT_EQ(
      planner.Plan(Problem(depot_, {0}, 100), options, token, nullptr, nullptr).status().code(),
      absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace riskplan
