// SessionTree (server/flight/session_tree.h): a Fly session's plans begin
// from the tree the previous plan left, pruned when cells close; every
// remainder stays admissible and exact; a reset, the size bound and the
// limits fall back as documented.
#include "server/flight/session_tree.h"

#include <cmath>
#include <memory>
#include <vector>

#include "core/map/demo_city.h"
#include "gtest/gtest.h"
#include "tests/core/planner_test_util.h"

namespace riskplan::server {
namespace {

using testing_planner::FindFlyablePose;
using testing_planner::ReEvaluate;
using testing_planner::WithClosedDisc;

class SessionTreeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    model_ = testing_planner::SmallCityModel(0.0, 0.0);
    goal_ = *FindFlyablePose(*model_, 1700, 1000, 0.0);
    start_ = *FindFlyablePose(*model_, 300, 1000, 0.0);
    later_ = *FindFlyablePose(*model_, 500, 1050, 0.0);
  }
  PlanOptions Options(int64_t iterations) const {
    PlanOptions o;
    o.seed = 5;
    o.budget.max_time_s = 0.0;
    o.budget.max_iterations = iterations;
    return o;
  }
  absl::StatusOr<PlanResult> Plan(SessionTree* tree, const std::shared_ptr<const RiskModel>& m,
                                  const Pose& from, const PlanOptions& o) {
    return tree->Plan(m, PlannerAlgorithm::kRiskRrtStar, from, goal_, o, nullptr, cancel_, nullptr);
  }
  static void ExpectExact(const RiskModel& model, const absl::StatusOr<PlanResult>& r) {
    ASSERT_TRUE(r.ok()) << r.status();
    ASSERT_TRUE(r->best.has_value());
    bool admissible = false;
    const double risk = ReEvaluate(model, r->best->waypoints, &admissible);
    EXPECT_TRUE(admissible);
    EXPECT_EQ(r->best->risk, risk);
  }
  std::shared_ptr<const RiskModel> model_;
  Pose goal_, start_, later_;
  CancellationToken cancel_;
};

TEST_F(SessionTreeTest, TheFirstPlanIsRiskRrtStarsAndTheNextBeginsFromItsTree) {
  SessionTree tree;
  const PlanOptions o = Options(400);
  auto first = Plan(&tree, model_, start_, o);
  ExpectExact(*model_, first);
  // The first plan is RISK_RRT_STAR's own, bit for bit.
  auto planner = MakePlanner(PlannerAlgorithm::kRiskRrtStar);
  ASSERT_TRUE(planner.ok());
  auto alone = (*planner)->Plan({model_, start_, goal_}, o, cancel_, nullptr);
  ASSERT_TRUE(alone.ok() && alone->best.has_value());
  EXPECT_EQ(first->best->risk, alone->best->risk);
  EXPECT_EQ(first->best->waypoints.size(), alone->best->waypoints.size());
  const int64_t nodes = tree.stats().tree_nodes;
  EXPECT_GT(nodes, 200);
  // The aircraft moved on: the next plan is a query into the same tree, and
  // a good one at once: with 20 iterations it is no worse than a plan from
  // the goal with 20 iterations, and the tree keeps growing.
  auto next = Plan(&tree, model_, later_, Options(20));
  ExpectExact(*model_, next);
  EXPECT_EQ(tree.stats().from_tree, 1);
  EXPECT_GT(tree.stats().tree_nodes, nodes);
  auto fresh = (*planner)->Plan({model_, later_, goal_}, Options(20), cancel_, nullptr);
  ASSERT_TRUE(fresh.ok());
  if (fresh->best.has_value()) EXPECT_LE(next->best->risk, fresh->best->risk);
}

TEST_F(SessionTreeTest, AClosedAreaPrunesTheTreeAndTheRemainderGoesRound) {
  SessionTree tree;
  ExpectExact(*model_, Plan(&tree, model_, start_, Options(400)));
  const int64_t nodes = tree.stats().tree_nodes;
  const std::shared_ptr<const RiskModel> zoned = WithClosedDisc(*model_, 1000, 1000, 150);
  auto round = Plan(&tree, zoned, later_, Options(100));
  ExpectExact(*zoned, round);
  EXPECT_EQ(tree.stats().from_tree, 1);
  EXPECT_GT(tree.stats().last_prune.cut_edges, 0);
  EXPECT_LT(tree.stats().last_prune.kept, nodes);
  for (const Pose& p : round->best->waypoints) {
    EXPECT_GT(std::hypot(p.x - 1000, p.y - 1000), 150.0);
  }
  // The zone removed: the base model again; the tree is checked (nothing to
  // cut: opening cells only adds room) and planned from.
  auto back = Plan(&tree, model_, later_, Options(50));
  ExpectExact(*model_, back);
  EXPECT_EQ(tree.stats().from_tree, 2);
  EXPECT_EQ(tree.stats().last_prune.cut_edges, 0);
  EXPECT_EQ(tree.stats().last_prune.orphaned, 0);
}

TEST_F(SessionTreeTest, ResetTheBoundAndLimitsPlanFromTheGoal) {
  SessionTree tree;
  ExpectExact(*model_, Plan(&tree, model_, start_, Options(200)));
  tree.Reset();
  EXPECT_EQ(tree.stats().resets, 1);
  EXPECT_EQ(tree.stats().tree_nodes, 0);
  ExpectExact(*model_, Plan(&tree, model_, later_, Options(100)));
  EXPECT_EQ(tree.stats().from_tree, 0);
  // A tree past half of max_nodes is dropped before the next plan.
  PlanOptions small = Options(100);
  small.params["max_nodes"] = 150;
  SessionTree bounded;
  ExpectExact(*model_, Plan(&bounded, model_, start_, small));
  ASSERT_GT(bounded.stats().tree_nodes, 75);
  ExpectExact(*model_, Plan(&bounded, model_, later_, small));
  EXPECT_EQ(bounded.stats().from_tree, 0);
  EXPECT_EQ(bounded.stats().resets, 1);
  // With flight limits the plan is MakePlanner's, from the goal, and honours them.
  SessionTree limited;
  PlanOptions o = Options(200);
  o.limits.max_length_m = 5000.0;
  auto r = Plan(&limited, model_, start_, o);
  ExpectExact(*model_, r);
  EXPECT_LE(r->best->length_m, 5000.0);
  EXPECT_EQ(limited.stats().tree_nodes, 0);
}

TEST_F(SessionTreeTest, ANewWindDropsTheTree) {
  SessionTree tree;
  ExpectExact(*model_, Plan(&tree, model_, start_, Options(200)));
  ASSERT_GT(tree.stats().tree_nodes, 0);
  const std::shared_ptr<const RiskModel> windy = testing_planner::SmallCityModel(6.0, 200.0);
  ExpectExact(*windy, Plan(&tree, windy, later_, Options(100)));
  EXPECT_EQ(tree.stats().from_tree, 0);
  EXPECT_EQ(tree.stats().resets, 1);
  // A map with the same layers but built on its own is another map.
  const std::shared_ptr<const RiskModel> other = testing_planner::SmallCityModel(6.0, 200.0);
  ExpectExact(*other, Plan(&tree, other, later_, Options(50)));
  EXPECT_EQ(tree.stats().from_tree, 0);
  EXPECT_EQ(tree.stats().resets, 2);
}

}  // namespace
}  // namespace riskplan::server
