// Cancellation, deadlines and admission control: a stopped plan frees its
// slot within milliseconds, and a plan past the limit is refused at once.
#include <signal.h>

#include <optional>
#include <thread>

#include "absl/synchronization/notification.h"
#include "absl/time/clock.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/integration/requests.h"
#include "tests/integration/server_process.h"

namespace riskplan::testing {
namespace {

using ::testing::HasSubstr;

class CancellationTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // One plan at a time: every test below can see whether the slot is free.
    auto server = ServerProcess::Start({"--plan_threads=1", "--max_running_plans=1"});
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = *std::move(server);
    client_ = std::make_unique<client::RiskplanClient>(server_->address());
  }

  // Time until a new plan is admitted: plans of one iteration are tried
  // until one is not refused with RESOURCE_EXHAUSTED.
  absl::Duration TimeUntilSlotFree(absl::Duration limit) {
    const absl::Time start = absl::Now();
    while (absl::Now() - start < limit) {
      PlanOutcome probe = RunPlan(*client_, SmallCityPlan(0, 1));
      if (probe.status.error_code() != grpc::StatusCode::RESOURCE_EXHAUSTED) {
        EXPECT_TRUE(probe.status.ok()) << probe.status.error_message();
        return absl::Now() - start;
      }
    }
    return absl::InfiniteDuration();
  }

  std::unique_ptr<ServerProcess> server_;
  std::unique_ptr<client::RiskplanClient> client_;
};

TEST_F(CancellationTest, AdmissionControlRefusesAtOnce) {
  absl::Notification first_update;
  grpc::Status long_status;
  std::thread long_plan([&] {
    long_status = client_->Plan(
        SmallCityPlan(20000),
        [&](const v1::PlanUpdate&) {
          if (!first_update.HasBeenNotified()) first_update.Notify();
          return true;
        },
        absl::Milliseconds(1500));
  });
  ASSERT_TRUE(first_update.WaitForNotificationWithTimeout(absl::Seconds(10)));

  const absl::Time start = absl::Now();
  PlanOutcome refused = RunPlan(*client_, SmallCityPlan(500));
  EXPECT_LT(absl::Now() - start, absl::Milliseconds(500));  // at once, not after waiting
  EXPECT_EQ(refused.status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(refused.status.error_message(),
              HasSubstr("maximum of 1 plans (--max_running_plans)"));
  EXPECT_TRUE(refused.updates.empty());
  // Evaluations are not plans: they still go through.
  v1::EvaluateRiskResponse response;
  EXPECT_TRUE(client_->EvaluateRisk(SmallCityPolyline(), &response).ok());
  long_plan.join();
  EXPECT_EQ(long_status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
}

TEST_F(CancellationTest, CancelStopsThePlanAndFreesTheSlotPromptly) {
  absl::Time cancelled_at;
  int updates = 0;
  const absl::Time start = absl::Now();
  grpc::Status status = client_->Plan(SmallCityPlan(30000), [&](const v1::PlanUpdate& u) {
    ++updates;
    EXPECT_FALSE(u.final());
    cancelled_at = absl::Now();
    return false;  // cancel after the first update
  });
  EXPECT_EQ(status.error_code(), grpc::StatusCode::CANCELLED);
  EXPECT_EQ(updates, 1);
  EXPECT_LT(absl::Now() - start, absl::Seconds(5));
  // The 30 s plan stopped: its slot is free again within milliseconds.
  const absl::Duration free_after = TimeUntilSlotFree(absl::Seconds(5));
  EXPECT_LT(free_after, absl::Milliseconds(500));
  // The server logs a plan when gRPC is done with it, which may be after the
  // client has moved on: stop the server (it exits once every call is done),
  // then read its log. With no call open it exits at once, well within its
  // 10 s grace period, even though this client is still connected; a call
  // gRPC never finished (a cancelled plan whose last write failed used to
  // be one) would hold it for the whole grace period.
  server_->Signal(SIGTERM);
  ASSERT_EQ(server_->Wait(absl::Seconds(5)), std::optional<int>(0));
  EXPECT_THAT(server_->Stderr(), HasSubstr("\"method\":\"PlanTrajectory\",\"code\":\"CANCELLED\""));
}

TEST_F(CancellationTest, StopsAtOnceWhenNoCallIsOpenThoughClientsAreConnected) {
  // An idle, connected client: its channel is not polled, so it would
  // acknowledge the server's GOAWAY only seconds later; the server does not
  // wait for that once its calls are done.
  v1::EvaluateRiskResponse response;
  ASSERT_TRUE(client_->EvaluateRisk(SmallCityPolyline(), &response).ok());
  ASSERT_TRUE(RunPlan(*client_, SmallCityPlan(0, 1)).status.ok());
  server_->Signal(SIGTERM);
  ASSERT_EQ(server_->Wait(absl::Seconds(5)), std::optional<int>(0));
  EXPECT_THAT(server_->Stderr(), HasSubstr("\"event\":\"stopped\""));
}

TEST_F(CancellationTest, DeadlineStopsThePlanAndFreesTheSlotPromptly) {
  const absl::Time start = absl::Now();
  PlanOutcome plan = RunPlan(*client_, SmallCityPlan(30000), absl::Milliseconds(400));
  const absl::Duration took = absl::Now() - start;
  EXPECT_EQ(plan.status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  EXPECT_GE(took, absl::Milliseconds(390));
  EXPECT_LT(took, absl::Milliseconds(1500));
  EXPECT_GE(plan.updates.size(), 1u);  // improvements streamed before the deadline
  for (const v1::PlanUpdate& u : plan.updates) EXPECT_FALSE(u.final());
  const absl::Duration free_after = TimeUntilSlotFree(absl::Seconds(5));
  EXPECT_LT(free_after, absl::Milliseconds(500));
}

TEST_F(CancellationTest, SlotIsFreeAfterANormalEnd) {
  PlanOutcome plan = RunPlan(*client_, SmallCityPlan(300));
  ASSERT_TRUE(plan.status.ok());
  // Right after the final message: nothing to wait for.
  PlanOutcome next = RunPlan(*client_, SmallCityPlan(0, 1));
  EXPECT_TRUE(next.status.ok()) << next.status.error_message();
}

}  // namespace
}  // namespace riskplan::testing
