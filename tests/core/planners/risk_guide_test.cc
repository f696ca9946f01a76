#include "core/planners/risk_guide.h"

#include <cmath>
#include <vector>

#include "gtest/gtest.h"
#include "tests/core/planner_test_util.h"

namespace riskplan {
namespace {

using testing_planner::DemoCityModel;
using testing_planner::DemoCityScenarios;
using testing_planner::Scenario;

TEST(RiskGuideTest, RouteWaypointsAreAdmissibleAndSpaced) {
  auto model = DemoCityModel();
  for (const Scenario& sc : DemoCityScenarios(*model)) {
    if (!sc.crosses_centre) continue;
    SCOPED_TRACE(sc.name);
    DirectRiskEvaluator evaluator;
    auto route = CoarseRiskRoute(*model, sc.start, sc.goal, 160.0, 400.0, &evaluator);
    ASSERT_TRUE(route.ok()) << route.status();
    ASSERT_FALSE(route->empty());
    // One batch over the coarse grid (50 x 50 cells, four headings each, at most).
    EXPECT_LE(evaluator.evaluated(), 4u * 50 * 50);
    Pose previous = sc.start;
    for (const Pose& w : *route) {
      EXPECT_EQ(model->CheckConfiguration(w), ViolationKind::kNone);
      EXPECT_GE(w.theta, 0.0);
      EXPECT_LT(w.theta, kTwoPi);
      EXPECT_LE(std::hypot(w.x - previous.x, w.y - previous.y), 2 * 400.0 + 1.0);
      previous = w;
    }
  }
}

TEST(RiskGuideTest, SameProblemGivesTheSameRoute) {
  auto model = DemoCityModel();
  const Scenario sc = DemoCityScenarios(*model)[0];
  DirectRiskEvaluator evaluator;
  auto a = CoarseRiskRoute(*model, sc.start, sc.goal, 160.0, 400.0, &evaluator);
  auto b = CoarseRiskRoute(*model, sc.start, sc.goal, 160.0, 400.0, &evaluator);
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_EQ(a->size(), b->size());
  for (size_t i = 0; i < a->size(); ++i) {
    EXPECT_EQ((*a)[i].x, (*b)[i].x);
    EXPECT_EQ((*a)[i].y, (*b)[i].y);
    EXPECT_EQ((*a)[i].z, (*b)[i].z);
    EXPECT_EQ((*a)[i].theta, (*b)[i].theta);
  }
}

TEST(RiskGuideTest, NoInteriorWaypointsBetweenNearPoses) {
  auto model = DemoCityModel();
  const Scenario sc = DemoCityScenarios(*model)[0];
  DirectRiskEvaluator evaluator;
  auto same = CoarseRiskRoute(*model, sc.start, sc.start, 160.0, 400.0, &evaluator);
  ASSERT_TRUE(same.ok());
  EXPECT_TRUE(same->empty());
}

}  // namespace
}  // namespace riskplan
