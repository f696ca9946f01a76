// The server with the accelerator engine behind its plans and evaluations
// (--cpu_workers): the CPU path is exact, so results must be bit for bit those
// of a server without the engine, and the engine's work shows in its metrics.
#include <regex>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/integration/requests.h"
#include "tests/integration/server_process.h"

namespace riskplan::testing {
namespace {

using ::testing::HasSubstr;

TEST(AccelEngineTest, PlansAndEvaluationsThroughCpuWorkersMatchTheDirectPath) {
  auto plain = ServerProcess::Start();
  ASSERT_TRUE(plain.ok()) << plain.status();
  auto with_engine = ServerProcess::Start(
      {"--cpu_workers=2", "--accel_caller_runs=false", "--metrics_listen=127.0.0.1:0"});
  ASSERT_TRUE(with_engine.ok()) << with_engine.status();
  const std::string log = (*with_engine)->Stderr();
  EXPECT_THAT(log, HasSubstr("\"event\":\"accel_engine\""));
  // The metrics address is logged before the readiness line, in a JSON line
  // whose key order is the logger's business.
  std::smatch match;
  ASSERT_TRUE(std::regex_search(
      log, match,
      std::regex("\\{[^\n]*\"detail\":\"([0-9.:]+)\"[^\n]*\"event\":\"metrics_listening\"|"
                 "\"event\":\"metrics_listening\",\"detail\":\"([0-9.:]+)\"")))
      << log;
  const std::string metrics_address = match[1].matched ? match[1] : match[2];

  client::RiskplanClient a((*plain)->address());
  client::RiskplanClient b((*with_engine)->address());
  // An iteration budget: bit-for-bit reproducible.
  const v1::PlanRequest request = SmallCityPlan(0, 400);
  PlanOutcome direct = RunPlan(a, request);
  PlanOutcome engine = RunPlan(b, request);
  ASSERT_TRUE(direct.status.ok()) << direct.status.error_message();
  ASSERT_TRUE(engine.status.ok()) << engine.status.error_message();
  ASSERT_FALSE(direct.updates.empty());
  ASSERT_FALSE(engine.updates.empty());
  // How many updates are sent depends on timing (a slow reader gets only the
  // newest); the final trajectory of an iteration budget does not.
  ASSERT_TRUE(direct.updates.back().final());
  ASSERT_TRUE(engine.updates.back().final());
  const v1::Trajectory& t1 = direct.updates.back().trajectory();
  const v1::Trajectory& t2 = engine.updates.back().trajectory();
  EXPECT_EQ(t1.risk(), t2.risk());
  ASSERT_EQ(t1.waypoints_size(), t2.waypoints_size());
  for (int i = 0; i < t1.waypoints_size(); ++i) {
    EXPECT_EQ(t1.waypoints(i).x(), t2.waypoints(i).x());
    EXPECT_EQ(t1.waypoints(i).z(), t2.waypoints(i).z());
  }
  EXPECT_EQ(direct.updates.back().configurations_evaluated(),
            engine.updates.back().configurations_evaluated());

  v1::EvaluateRiskRequest eval = SmallCityPolyline();
  eval.set_include_samples(true);
  v1::EvaluateRiskResponse r1;
  v1::EvaluateRiskResponse r2;
  ASSERT_TRUE(a.EvaluateRisk(eval, &r1).ok());
  ASSERT_TRUE(b.EvaluateRisk(eval, &r2).ok());
  EXPECT_EQ(r1.risk(), r2.risk());
  ASSERT_EQ(r1.samples_size(), r2.samples_size());

  // Every configuration went to the CPU workers (callers do not compute).
  absl::StatusOr<std::string> text = HttpGet(metrics_address, "/metrics");
  ASSERT_TRUE(text.ok()) << text.status();
  EXPECT_THAT(*text, HasSubstr("riskplan_accel_configurations_total{runner=\"caller\"} 0"));
  std::smatch count;
  ASSERT_TRUE(std::regex_search(
      *text, count,
      std::regex("riskplan_accel_configurations_total\\{runner=\"cpu-0\"\\} ([0-9]+)")));
  std::smatch count1;
  ASSERT_TRUE(std::regex_search(
      *text, count1,
      std::regex("riskplan_accel_configurations_total\\{runner=\"cpu-1\"\\} ([0-9]+)")));
  EXPECT_EQ(std::stoull(count[1]) + std::stoull(count1[1]),
            engine.updates.back().configurations_evaluated() + r2.samples_size());
}

}  // namespace
}  // namespace riskplan::testing
