// Prometheus metrics over HTTP (--metrics_listen), read after real RPCs.
#include <regex>
#include <thread>

#include "absl/strings/str_format.h"
#include "absl/time/clock.h"

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/integration/requests.h"
#include "tests/integration/server_process.h"

namespace riskplan::testing {
namespace {

using ::testing::HasSubstr;

TEST(MetricsTest, CountsRpcsByMethodAndCodeAndPlans) {
  auto started = ServerProcess::Start({"--metrics_listen=127.0.0.1:0"});
  ASSERT_TRUE(started.ok()) << started.status();
  std::unique_ptr<ServerProcess> server = *std::move(started);
  // The metrics address is logged before the readiness line.
  const std::string metrics_address = MetricsAddress(server->Stderr());
  ASSERT_FALSE(metrics_address.empty()) << server->Stderr();

  client::RiskplanClient client(server->Channel());
  ASSERT_TRUE(client.Ping().ok());
  ASSERT_TRUE(client.Ping().ok());
  v1::EvaluateRiskRequest bad = SmallCityPolyline();
  bad.set_map("nowhere");
  v1::EvaluateRiskResponse response;
  ASSERT_EQ(client.EvaluateRisk(bad, &response).error_code(), grpc::StatusCode::NOT_FOUND);
  PlanOutcome plan = RunPlan(client, SmallCityPlan(0, 100));
  ASSERT_TRUE(plan.status.ok());
  // Unary RPCs are counted before their answer is sent, and a plan's
  // duration and the running-plans gauge before its final message.
  absl::StatusOr<std::string> text = HttpGet(metrics_address, "/metrics");
  ASSERT_TRUE(text.ok()) << text.status();
  EXPECT_THAT(*text, HasSubstr("riskplan_rpcs_total{code=\"OK\",method=\"Ping\"} 2"));
  EXPECT_THAT(*text,
              HasSubstr("riskplan_rpcs_total{code=\"NOT_FOUND\",method=\"EvaluateRisk\"} 1"));
  EXPECT_THAT(*text, HasSubstr("riskplan_running_plans 0"));
  EXPECT_THAT(*text,
              HasSubstr("riskplan_plan_duration_seconds_count{end_reason=\"BUDGET_EXHAUSTED\"} 1"));
  EXPECT_THAT(*text, HasSubstr("riskplan_map_memory_bytes{map=\"demo-city\"}"));
}

// The autoscaler's metric: a PlanTrajectory plan is one mission, a fleet's
// missions count one by one, queued or planning.
TEST(MetricsTest, MissionsInFlightCountsPlansAndEveryFleetMission) {
  auto started = ServerProcess::Start(
      {"--metrics_listen=127.0.0.1:0", "--plan_threads=1", "--max_running_plans=1"});
  ASSERT_TRUE(started.ok()) << started.status();
  std::unique_ptr<ServerProcess> server = *std::move(started);
  const std::string metrics_address = MetricsAddress(server->Stderr());
  const auto in_flight = [&]() -> double {
    absl::StatusOr<std::string> text = HttpGet(metrics_address, "/metrics");
    if (!text.ok()) return -1;
    return MetricValue(*text, "riskplan_missions_in_flight").value_or(-1);
  };
  // Waits (bounded) until the gauge reads `want`; returns what it read last.
  const auto await = [&](double want) {
    double got = in_flight();
    for (int i = 0; i < 3000 && got != want; ++i) {
      absl::SleepFor(absl::Milliseconds(20));
      got = in_flight();
    }
    return got;
  };
  EXPECT_EQ(in_flight(), 0);

  client::RiskplanClient client(server->Channel());
  // A long plan takes the one slot.
  grpc::ClientContext plan_context;
  auto plan = client.stub().PlanTrajectory(&plan_context, SmallCityPlan(600000));
  v1::PlanUpdate update;
  ASSERT_TRUE(plan->Read(&update));
  EXPECT_EQ(await(1), 1);

  // Three fleet missions, each its own group (a seed each): all queued
  // behind the plan, and counted.
  v1::FleetRequest fleet;
  for (int m = 0; m < 3; ++m) {
    v1::FleetMission* mission = fleet.add_missions();
    mission->set_id(absl::StrFormat("m%d", m));
    *mission->mutable_request() = SmallCityPlan(0, 50);
    mission->mutable_request()->set_seed(m + 1);
  }
  grpc::ClientContext fleet_context;
  auto fleet_stream = client.stub().PlanFleet(&fleet_context, fleet);
  EXPECT_EQ(await(4), 4);

  // The plan ends: the fleet's missions plan one by one, each leaving the
  // count when it ends, down to 0.
  plan_context.TryCancel();
  while (plan->Read(&update)) {
  }
  v1::FleetUpdate fleet_update;
  int finals = 0;
  while (fleet_stream->Read(&fleet_update)) finals += fleet_update.update().final();
  EXPECT_TRUE(fleet_stream->Finish().ok());
  EXPECT_EQ(finals, 3);
  EXPECT_EQ(await(0), 0);
}

TEST(MetricsTest, ReportsTheMemoryAndBoundsOfTheServersCaches) {
  auto started = ServerProcess::Start(
      {"--metrics_listen=127.0.0.1:0", "--model_cache_size=3", "--feasibility_cache_size=2"});
  ASSERT_TRUE(started.ok()) << started.status();
  std::unique_ptr<ServerProcess> server = *std::move(started);
  const std::string metrics_address = MetricsAddress(server->Stderr());
  ASSERT_FALSE(metrics_address.empty()) << server->Stderr();
  const auto metric = [&](const std::string& series) {
    absl::StatusOr<std::string> text = HttpGet(metrics_address, "/metrics");
    EXPECT_TRUE(text.ok()) << text.status();
    return text.ok() ? MetricValue(*text, series) : std::nullopt;
  };
  // The default model (impact table) is built at start-up; nothing else yet.
  EXPECT_GT(metric("riskplan_model_cache_bytes{kind=\"default\"}").value_or(0), 1e6);
  EXPECT_EQ(metric("riskplan_model_cache_bytes{kind=\"overridden\"}"), 0.0);
  EXPECT_EQ(metric("riskplan_model_cache_limit_models"), 3.0);
  EXPECT_EQ(metric("riskplan_feasibility_cache_bytes"), 0.0);
  EXPECT_EQ(metric("riskplan_feasibility_cache_limit_checkers"), 2.0);

  client::RiskplanClient client(server->Channel());
  // An evaluation with the two-tier check builds a checker (8 bytes per
  // cell of the 400 x 400 map and its coarse tier); one with overridden
  // glide parameters builds a model with its own glide layer.
  v1::EvaluateRiskRequest two_tier = SmallCityPolyline();
  two_tier.mutable_two_tier()->set_enabled(true);
  v1::EvaluateRiskResponse response;
  ASSERT_TRUE(client.EvaluateRisk(two_tier, &response).ok());
  EXPECT_EQ(metric("riskplan_feasibility_cache_checkers"), 1.0);
  EXPECT_GE(metric("riskplan_feasibility_cache_bytes").value_or(0), 400.0 * 400 * 8);
  v1::EvaluateRiskRequest overridden = SmallCityPolyline();
  overridden.mutable_model_params()->set_glide_ratio(12.0);
  ASSERT_TRUE(client.EvaluateRisk(overridden, &response).ok());
  EXPECT_EQ(metric("riskplan_model_cache_models"), 1.0);
  EXPECT_GE(metric("riskplan_model_cache_bytes{kind=\"overridden\"}").value_or(0), 400.0 * 400 * 8);

  // Guided plans (an iteration budget: the field's build runs to its end):
  // the first builds its goal's field, the second, to the same goal, finds it.
  EXPECT_EQ(metric("riskplan_guide_field_cache_entries"), 0.0);
  EXPECT_EQ(metric("riskplan_guide_field_cache_limit_bytes"), 256.0 * 1024 * 1024);
  v1::PlanRequest guided = SmallCityPlan(0, 50);
  (*guided.mutable_planner_params())["guide"] = 1.0;
  (*guided.mutable_planner_params())["guide_field_m"] = 250.0;
  ASSERT_TRUE(RunPlan(client, guided).status.ok());
  EXPECT_EQ(metric("riskplan_guide_field_cache_misses_total"), 1.0);
  EXPECT_EQ(metric("riskplan_guide_field_cache_hits_total"), 0.0);
  EXPECT_EQ(metric("riskplan_guide_field_cache_entries"), 1.0);
  EXPECT_GT(metric("riskplan_guide_field_cache_bytes").value_or(0), 1000.0);
  guided.set_seed(8);
  ASSERT_TRUE(RunPlan(client, guided).status.ok());
  EXPECT_EQ(metric("riskplan_guide_field_cache_hits_total"), 1.0);
  EXPECT_EQ(metric("riskplan_guide_field_cache_misses_total"), 1.0);
}

}  // namespace
}  // namespace riskplan::testing
