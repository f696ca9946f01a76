// PlanTrajectory end to end: the real server binary and the real client.
#include <cmath>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/integration/requests.h"
#include "tests/integration/server_process.h"
#include "tests/integration/shared_server_test.h"

namespace riskplan::testing {
namespace {

class PlanStreamTest : public SharedServerTest<PlanStreamTest> {};

// A deadline on every plan below: a server that ignored a budget fails the
// test instead of running to its 600 s cap.
constexpr absl::Duration kPlanDeadline = absl::Seconds(120);

TEST_F(PlanStreamTest, StreamsImprovementsThenOneFinalMessage) {
  PlanOutcome plan = RunPlan(*client_, SmallCityPlan(800), kPlanDeadline);
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
  // The time budget, by the server's own clock: the plan does not end before
  // it (a loaded machine can only make it end later, by an iteration and
  // whatever the scheduler adds, so no upper bound but the deadline above).
  EXPECT_GE(final_update.elapsed_s(), 0.8);
  for (size_t i = 1; i < plan.updates.size(); ++i) {
    EXPECT_GE(plan.updates[i].elapsed_s(), plan.updates[i - 1].elapsed_s());
  }
  EXPECT_GT(final_update.iterations(), 0);
  EXPECT_GT(final_update.configurations_evaluated(), 0u);
  EXPECT_GE(final_update.improvements(), static_cast<int64_t>(plan.updates.size()) - 1);
  // The path starts at the start and ends at the goal.
  const v1::Trajectory& best = final_update.trajectory();
  EXPECT_NEAR(best.path(0).x(), 300.0, 1e-6);
  EXPECT_NEAR(best.path(best.path_size() - 1).y(), 1625.0, 1e-6);
}

TEST_F(PlanStreamTest, RiskNeverIncreasesAcrossUpdates) {
  // An iteration budget: the planner's improvements are the same on any
  // machine (same seed); how many of them reach the client depends on how
  // fast it reads (a newer one replaces one not yet sent), but never fewer
  // than the first and the final message.
  v1::PlanRequest request = SmallCityPlan(0, 1500);
  request.set_min_update_interval_ms(0);
  PlanOutcome plan = RunPlan(*client_, request, kPlanDeadline);
  ASSERT_TRUE(plan.status.ok()) << plan.status.error_message();
  ASSERT_GE(plan.updates.back().improvements(), 3);
  ASSERT_GE(plan.updates.size(), 2u);
  EXPECT_LE(static_cast<int64_t>(plan.updates.size()), plan.updates.back().improvements() + 1);
  EXPECT_LT(plan.updates.back().trajectory().risk(), plan.updates.front().trajectory().risk());
  for (size_t i = 1; i < plan.updates.size(); ++i) {
    EXPECT_LE(plan.updates[i].trajectory().risk(), plan.updates[i - 1].trajectory().risk())
        << "update " << i + 1;
    EXPECT_GE(plan.updates[i].iterations(), plan.updates[i - 1].iterations());
  }
}

TEST_F(PlanStreamTest, EvaluateRiskOfTheFinalTrajectoryEqualsThePlansRisk) {
  PlanOutcome plan = RunPlan(*client_, SmallCityPlan(600), kPlanDeadline);
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
  PlanOutcome a = RunPlan(*client_, request, kPlanDeadline);
  PlanOutcome b = RunPlan(*client_, request, kPlanDeadline);
  ASSERT_TRUE(a.status.ok() && b.status.ok());
  EXPECT_EQ(a.updates.back().iterations(), 300);
  EXPECT_EQ(a.updates.back().trajectory().risk(), b.updates.back().trajectory().risk());
  EXPECT_EQ(a.updates.back().trajectory().waypoints_size(),
            b.updates.back().trajectory().waypoints_size());
}

TEST_F(PlanStreamTest, FinalMessageCarriesTheTreeWhenAsked) {
  v1::PlanRequest request = SmallCityPlan(0, 200);
  request.set_include_tree(true);
  PlanOutcome plan = RunPlan(*client_, request, kPlanDeadline);
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
  PlanOutcome plan = RunPlan(*client_, request, kPlanDeadline);
  ASSERT_TRUE(plan.status.ok()) << plan.status.error_message();
  ASSERT_GE(plan.updates.size(), 2u);
  // The server starts the non-final updates at least 300 ms apart by its own
  // clock, all of them after the planner's first improvement and before its
  // end: over the planner's elapsed E, at most E / 0.3 + 1 of them, and one
  // more for the moments between the planner's clock and the stream's. The
  // arrival times at the client are not used: a loaded client can receive
  // two updates in a row that were sent 300 ms apart. Without the interval
  // every improvement found would be sent (dozens in 1.2 s on this map,
  // ~5 on a slow machine, where this bound is ~10).
  const v1::PlanUpdate& final_update = plan.updates.back();
  const int64_t non_final = static_cast<int64_t>(plan.updates.size()) - 1;
  const int64_t most = static_cast<int64_t>(std::floor(final_update.elapsed_s() / 0.3)) + 2;
  EXPECT_LE(non_final, most) << "the planner ran " << final_update.elapsed_s() << " s";
  EXPECT_GE(final_update.improvements(), non_final);
  EXPECT_TRUE(final_update.final());
}

TEST_F(PlanStreamTest, NoSolutionIsANormalEnd) {
  // One iteration cannot connect start and goal 2 km apart (without the
  // guide route, which can: it is found before the first iteration).
  v1::PlanRequest request = SmallCityPlan(0, 1);
  (*request.mutable_planner_params())["guide_cell_m"] = 0.0;
  PlanOutcome plan = RunPlan(*client_, request, kPlanDeadline);
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
