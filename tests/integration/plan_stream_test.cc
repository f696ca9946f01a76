// PlanTrajectory end to end: the real server binary and the real client.
#include <cmath>

#include "absl/time/clock.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/integration/requests.h"
#include "tests/integration/server_process.h"
#include "tests/integration/shared_server_test.h"

namespace riskplan::testing {
namespace {

class PlanStreamTest : public SharedServerTest<PlanStreamTest> {};

TEST_F(PlanStreamTest, StreamsImprovementsThenOneFinalMessage) {
  PlanOutcome plan = RunPlan(*client_, SmallCityPlan(800));
  ASSERT_TRUE(plan.status.ok()) << plan.status.error_message();
  ASSERT_GE(plan.updates.size(), 2u);  // at least one improvement and the final message
  for (size_t i = 0; i < plan.updates.size(); ++i) {
    const v1::PlanUpdate& u = plan.updates[i];
    EXPECT_EQ(u.sequence(), i + 1);  // contiguous, from 1
    const bool last = i + 1 == plan.updates.size();
    EXPECT_EQ(u.final(), last);
    EXPECT_EQ(u.end_reason() != v1::END_REASON_UNSPECIFIED, last);
    ASSERT_TRUE(u.has_trajectory());
    EXPECT_GE(u.trajectory().waypoints_size(), 2);
    EXPECT_GE(u.trajectory().path_size(), 2);
    EXPECT_GT(u.trajectory().risk(), 0.0);
    EXPECT_GT(u.trajectory().length_m(), 1400.0 * std::sqrt(2.0) - 1.0);  // >= straight line
  }
  const v1::PlanUpdate& final_update = plan.updates.back();
  EXPECT_EQ(final_update.end_reason(), v1::BUDGET_EXHAUSTED);
  EXPECT_NEAR(final_update.elapsed_s(), 0.8, 0.25);
  EXPECT_GT(final_update.iterations(), 0);
  EXPECT_GT(final_update.configurations_evaluated(), 0u);
  EXPECT_GE(final_update.improvements(), static_cast<int64_t>(plan.updates.size()) - 1);
  // The path starts at the start and ends at the goal.
  const v1::Trajectory& best = final_update.trajectory();
  EXPECT_NEAR(best.path(0).x(), 300.0, 1e-6);
  EXPECT_NEAR(best.path(best.path_size() - 1).y(), 1625.0, 1e-6);
}

TEST_F(PlanStreamTest, RiskNeverIncreasesAcrossUpdates) {
  v1::PlanRequest request = SmallCityPlan(1000);
  request.set_min_update_interval_ms(0);
  PlanOutcome plan = RunPlan(*client_, request);
  ASSERT_TRUE(plan.status.ok()) << plan.status.error_message();
  ASSERT_GE(plan.updates.size(), 3u);
  for (size_t i = 1; i < plan.updates.size(); ++i) {
    EXPECT_LE(plan.updates[i].trajectory().risk(), plan.updates[i - 1].trajectory().risk())
        << "update " << i + 1;
    EXPECT_GE(plan.updates[i].iterations(), plan.updates[i - 1].iterations());
  }
}

TEST_F(PlanStreamTest, EvaluateRiskOfTheFinalTrajectoryEqualsThePlansRisk) {
  PlanOutcome plan = RunPlan(*client_, SmallCityPlan(600));
  ASSERT_TRUE(plan.status.ok()) << plan.status.error_message();
  const v1::Trajectory& best = plan.updates.back().trajectory();
  v1::EvaluateRiskRequest eval;
  eval.set_map("demo-city");
  *eval.mutable_waypoints()->mutable_poses() = best.waypoints();
  v1::EvaluateRiskResponse response;
  grpc::Status status = client_->EvaluateRisk(eval, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_TRUE(response.admissible());
  EXPECT_NEAR(response.risk(), best.risk(), 1e-9 * best.risk());
  EXPECT_NEAR(response.length_m(), best.length_m(), 1e-9 * best.length_m());
  EXPECT_EQ(response.pieces_size(), best.waypoints_size() - 1);
}

TEST_F(PlanStreamTest, IterationBudgetIsReproducible) {
  v1::PlanRequest request = SmallCityPlan(0, 300);
  PlanOutcome a = RunPlan(*client_, request);
  PlanOutcome b = RunPlan(*client_, request);
  ASSERT_TRUE(a.status.ok() && b.status.ok());
  EXPECT_EQ(a.updates.back().iterations(), 300);
  EXPECT_EQ(a.updates.back().trajectory().risk(), b.updates.back().trajectory().risk());
  EXPECT_EQ(a.updates.back().trajectory().waypoints_size(),
            b.updates.back().trajectory().waypoints_size());
}

TEST_F(PlanStreamTest, FinalMessageCarriesTheTreeWhenAsked) {
  v1::PlanRequest request = SmallCityPlan(0, 200);
  request.set_include_tree(true);
  PlanOutcome plan = RunPlan(*client_, request);
  ASSERT_TRUE(plan.status.ok());
  const v1::PlanUpdate& final_update = plan.updates.back();
  EXPECT_GT(final_update.tree_edges_size(), 10);
  EXPECT_LE(final_update.tree_edges_size(), final_update.tree_size());
  EXPECT_FALSE(final_update.tree_truncated());
  for (size_t i = 0; i + 1 < plan.updates.size(); ++i) {
    EXPECT_EQ(plan.updates[i].tree_edges_size(), 0);  // only on the final message
  }
}

TEST_F(PlanStreamTest, MinimumIntervalSpacesUpdates) {
  v1::PlanRequest request = SmallCityPlan(1200);
  request.set_min_update_interval_ms(300);
  std::vector<absl::Time> received;
  std::vector<v1::PlanUpdate> updates;
  grpc::Status status = client_->Plan(request, [&](const v1::PlanUpdate& u) {
    received.push_back(absl::Now());
    updates.push_back(u);
    return true;
  });
  ASSERT_TRUE(status.ok());
  ASSERT_GE(updates.size(), 2u);
  // Non-final updates at least 300 ms apart when sent; on arrival, network
  // and scheduling jitter may shorten a gap a little, never to the few
  // milliseconds between improvements sent without the interval. So at most
  // 1200 / 300 + 1 of them; the final message is never held back.
  for (size_t i = 1; i + 1 < updates.size(); ++i) {
    EXPECT_GE(received[i] - received[i - 1], absl::Milliseconds(200)) << "update " << i + 1;
  }
  EXPECT_LE(updates.size(), 6u);
  EXPECT_GE(updates.back().improvements(), static_cast<int64_t>(updates.size()) - 1);
}

TEST_F(PlanStreamTest, NoSolutionIsANormalEnd) {
  // One iteration cannot connect start and goal 2 km apart (without the
  // guide route, which can: it is found before the first iteration).
  v1::PlanRequest request = SmallCityPlan(0, 1);
  (*request.mutable_planner_params())["guide_cell_m"] = 0.0;
  PlanOutcome plan = RunPlan(*client_, request);
  ASSERT_TRUE(plan.status.ok()) << plan.status.error_message();
  ASSERT_EQ(plan.updates.size(), 1u);
  EXPECT_TRUE(plan.updates[0].final());
  EXPECT_EQ(plan.updates[0].end_reason(), v1::NO_SOLUTION);
  EXPECT_FALSE(plan.updates[0].has_trajectory());
}

TEST_F(PlanStreamTest, EveryRpcIsLoggedAsOneJsonLine) {
  ASSERT_TRUE(client_->Ping().ok());
  v1::ListMapsResponse maps;
  ASSERT_TRUE(client_->ListMaps(&maps).ok());
  const std::string log = server_->Stderr();
  EXPECT_THAT(log, ::testing::HasSubstr("\"event\":\"rpc\",\"method\":\"Ping\",\"code\":\"OK\""));
  EXPECT_THAT(log, ::testing::HasSubstr("\"method\":\"ListMaps\",\"code\":\"OK\",\"duration_ms\""));
}

}  // namespace
}  // namespace riskplan::testing
