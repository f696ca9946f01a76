// Prometheus metrics over HTTP (--metrics_listen), read after real RPCs.
#include <regex>

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
  std::smatch match;
  const std::string log = server->Stderr();
  ASSERT_TRUE(std::regex_search(
      log, match, std::regex("\"event\":\"metrics_listening\",\"detail\":\"([0-9.:]+)\"")));
  const std::string metrics_address = match[1];

  client::RiskplanClient client(server->address());
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

}  // namespace
}  // namespace riskplan::testing
