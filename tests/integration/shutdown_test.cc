// Graceful shutdown: SIGTERM turns health NOT_SERVING, new calls get
// UNAVAILABLE, a running plan ends with its best trajectory (end reason
// SHUTDOWN) within the grace period, and the server exits 0.
#include <signal.h>

#include <thread>

#include "absl/synchronization/notification.h"
#include "absl/time/clock.h"
#include "gmock/gmock.h"
#include "grpc/health/v1/health.grpc.pb.h"
#include "gtest/gtest.h"
#include "tests/integration/requests.h"
#include "tests/integration/server_process.h"

namespace riskplan::testing {
namespace {

using grpc::health::v1::HealthCheckRequest;
using grpc::health::v1::HealthCheckResponse;

TEST(ShutdownTest, DrainsOnSigterm) {
  auto started = ServerProcess::Start({"--grace_period_ms=2000"});
  ASSERT_TRUE(started.ok()) << started.status();
  std::unique_ptr<ServerProcess> server = *std::move(started);
  client::RiskplanClient client(server->Channel());

  HealthCheckResponse::ServingStatus health = HealthCheckResponse::UNKNOWN;
  ASSERT_TRUE(client.CheckHealth("", &health).ok());
  EXPECT_EQ(health, HealthCheckResponse::SERVING);
  ASSERT_TRUE(client.CheckHealth("riskplan.v1.Planner", &health).ok());
  EXPECT_EQ(health, HealthCheckResponse::SERVING);

  // Watch the health status: the stream tells us when it changes.
  grpc::ClientContext watch_context;
  client::SetTimeout(&watch_context, absl::Seconds(120));  // fails rather than hangs
  auto health_stub = grpc::health::v1::Health::NewStub(client.channel());
  HealthCheckRequest watch_request;
  auto watch = health_stub->Watch(&watch_context, watch_request);
  HealthCheckResponse watched;
  ASSERT_TRUE(watch->Read(&watched));
  EXPECT_EQ(watched.status(), HealthCheckResponse::SERVING);

  // A plan far longer than the grace period.
  absl::Notification first_update;
  PlanOutcome plan;
  std::thread planner([&] {
    plan.status = client.Plan(SmallCityPlan(60000), [&](const v1::PlanUpdate& u) {
      plan.updates.push_back(u);
      if (!first_update.HasBeenNotified()) first_update.Notify();
      return true;
    });
  });
  ASSERT_TRUE(first_update.WaitForNotificationWithTimeout(absl::Seconds(60)));

  const absl::Time sigterm_at = absl::Now();
  server->Signal(SIGTERM);
  ASSERT_TRUE(watch->Read(&watched));
  EXPECT_EQ(watched.status(), HealthCheckResponse::NOT_SERVING);
  ASSERT_TRUE(client.CheckHealth("riskplan.v1.Planner", &health).ok());
  EXPECT_EQ(health, HealthCheckResponse::NOT_SERVING);

  // New calls are refused while the running plan drains.
  PlanOutcome refused = RunPlan(client, SmallCityPlan(300));
  EXPECT_EQ(refused.status.error_code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_THAT(refused.status.error_message(), ::testing::HasSubstr("shutting down"));
  v1::EvaluateRiskResponse response;
  EXPECT_EQ(client.EvaluateRisk(SmallCityPolyline(), &response).error_code(),
            grpc::StatusCode::UNAVAILABLE);

  planner.join();
  ASSERT_TRUE(plan.status.ok()) << plan.status.error_message();
  const v1::PlanUpdate& final_update = plan.updates.back();
  EXPECT_TRUE(final_update.final());
  EXPECT_EQ(final_update.end_reason(), v1::SHUTDOWN);
  ASSERT_TRUE(final_update.has_trajectory());  // its best trajectory, not nothing
  EXPECT_LE(final_update.trajectory().risk(), plan.updates.front().trajectory().risk());
  // The plan had the grace period but for its last second (a lower bound: a
  // loaded machine only makes the end later).
  EXPECT_GE(absl::Now() - sigterm_at, absl::Milliseconds(1000));

  // The drain completed within the grace period (and the two seconds the
  // server allows past it): the server's own verdict, exit code 0; a drain
  // still running then would have ended the process with code 1 and a
  // drain_timeout event.
  std::optional<int> exit_code = server->Wait(absl::Seconds(60));
  ASSERT_TRUE(exit_code.has_value());
  EXPECT_EQ(*exit_code, 0);
  watch_context.TryCancel();
  // And in this order: the drain starts, the plan is stopped, it ends with
  // SHUTDOWN, the server stops.
  const std::string log = server->Stderr();
  EXPECT_THAT(log, ::testing::Not(::testing::HasSubstr("drain_timeout")));
  const size_t draining = log.find("\"event\":\"draining\"");
  const size_t stopping = log.find("\"event\":\"stopping_plans\"");
  const size_t shutdown = log.find("end_reason=SHUTDOWN");
  const size_t stopped = log.find("\"event\":\"stopped\"");
  ASSERT_NE(draining, std::string::npos) << log;
  ASSERT_NE(stopping, std::string::npos) << log;
  ASSERT_NE(shutdown, std::string::npos) << log;
  ASSERT_NE(stopped, std::string::npos) << log;
  EXPECT_LT(draining, stopping);
  EXPECT_LT(stopping, shutdown);
  EXPECT_LT(shutdown, stopped);
}

TEST(ShutdownTest, IdleServerExitsAtOnce) {
  // With nothing to drain the server does not wait for its grace period: it
  // exits within a wait that is half of it.
  auto started = ServerProcess::Start({"--grace_period_ms=120000"});
  ASSERT_TRUE(started.ok()) << started.status();
  std::unique_ptr<ServerProcess> server = *std::move(started);
  server->Signal(SIGINT);
  std::optional<int> exit_code = server->Wait(absl::Seconds(60));
  ASSERT_TRUE(exit_code.has_value());
  EXPECT_EQ(*exit_code, 0);
  EXPECT_THAT(server->Stderr(), ::testing::HasSubstr("running_plans=0"));
}

TEST(ShutdownTest, RefusesToStartOnABadMapsDirectory) {
  char dir_template[] = "/tmp/riskplan-maps-XXXXXX";
  ASSERT_NE(mkdtemp(dir_template), nullptr);
  const std::string dir = dir_template;
  ASSERT_EQ(RunCommand("mkdir -p " + dir + "/broken && echo '{not json' > " + dir +
                       "/broken/manifest.json")
                .exit_code,
            0);
  auto started = ServerProcess::Start({"--maps=" + dir}, absl::Seconds(30));
  ASSERT_FALSE(started.ok());
  EXPECT_THAT(std::string(started.status().message()),
              ::testing::HasSubstr("riskplan-server: cannot start: maps directory"));
  EXPECT_THAT(std::string(started.status().message()), ::testing::HasSubstr("broken"));
  // The exit code is 1.
  CommandResult result =
      RunCommand(std::string(RISKPLAN_BIN_DIR) +
                 "/riskplan-server --listen=127.0.0.1:0 --maps=" + dir + " 2>&1");
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_THAT(result.output, ::testing::HasSubstr("cannot start"));
  RunCommand("rm -rf " + dir);
}

}  // namespace
}  // namespace riskplan::testing
