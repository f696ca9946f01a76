// Cancellation, deadlines and admission control: a stopped plan frees its
// slot, and a plan past the limit is refused at once rather than queued.
#include <signal.h>

#include <optional>
#include <regex>
#include <string>

#include "absl/time/clock.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/integration/requests.h"
#include "tests/integration/server_process.h"

namespace riskplan::testing {
namespace {

using ::testing::HasSubstr;

// Plans that only a cancellation, a deadline or a shutdown can end: their
// budget is the server's cap, ten minutes. Every bound on time below is far
// under it, so passing one says the plan was stopped, not that the machine
// was fast; how soon the planner stops once told to is checked to the
// iteration in tests/core/planners, with no clock.
constexpr int64_t kEndlessPlanMs = 600000;
// How long a stopped plan may take to free its slot, or a call to come back,
// on a loaded machine: generous, yet a tenth of kEndlessPlanMs.
constexpr absl::Duration kPatience = absl::Seconds(60);

class CancellationTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // One plan at a time: every test below can see whether the slot is free.
    // A grace period far longer than the waits for exit below, so that an
    // exit within them says the server did not wait for it.
    auto server = ServerProcess::Start(
        {"--plan_threads=1", "--max_running_plans=1", "--grace_period_ms=120000"});
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = *std::move(server);
    client_ = std::make_unique<client::RiskplanClient>(server_->Channel());
  }

  // Whether a new plan is admitted within `limit`: plans of one iteration are
  // tried until one is not refused with RESOURCE_EXHAUSTED.
  bool SlotFreesWithin(absl::Duration limit) {
    const absl::Time start = absl::Now();
    while (absl::Now() - start < limit) {
      PlanOutcome probe = RunPlan(*client_, SmallCityPlan(0, 1), kPatience);
      if (probe.status.error_code() != grpc::StatusCode::RESOURCE_EXHAUSTED) {
        EXPECT_TRUE(probe.status.ok()) << probe.status.error_message();
        return true;
      }
    }
    return false;
  }

  std::unique_ptr<ServerProcess> server_;
  std::unique_ptr<client::RiskplanClient> client_;
};

// The duration_ms that the server logged for its PlanTrajectory call that
// ended with `code` (the whole call by the server's clock), or -1.
double LoggedCallMs(const std::string& log, const std::string& code) {
  std::smatch match;
  const std::regex line("\"method\":\"PlanTrajectory\",\"code\":\"" + code +
                        "\",\"duration_ms\":([0-9.]+)");
  return std::regex_search(log, match, line) ? std::stod(match[1]) : -1.0;
}

TEST_F(CancellationTest, AdmissionControlRefusesAtOnce) {
  // A plan that holds the only slot until this test cancels it.
  grpc::ClientContext long_context;
  std::unique_ptr<grpc::ClientReader<v1::PlanUpdate>> long_plan =
      client_->stub().PlanTrajectory(&long_context, SmallCityPlan(kEndlessPlanMs));
  v1::PlanUpdate update;
  ASSERT_TRUE(long_plan->Read(&update)) << long_plan->Finish().error_message();

  // Refused while that plan runs: a plan that waited for the slot instead
  // would wait until this test cancels the first one below, so its call
  // would end with DEADLINE_EXCEEDED here.
  PlanOutcome refused = RunPlan(*client_, SmallCityPlan(500), kPatience);
  EXPECT_EQ(refused.status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(refused.status.error_message(),
              HasSubstr("maximum of 1 plans (--max_running_plans)"));
  EXPECT_TRUE(refused.updates.empty());
  // Evaluations are not plans: they still go through.
  v1::EvaluateRiskResponse response;
  EXPECT_TRUE(client_->EvaluateRisk(SmallCityPolyline(), &response).ok());

  long_context.TryCancel();
  while (long_plan->Read(&update)) EXPECT_FALSE(update.final());
  EXPECT_EQ(long_plan->Finish().error_code(), grpc::StatusCode::CANCELLED);
}

TEST_F(CancellationTest, CancelStopsThePlanAndFreesTheSlotPromptly) {
  int updates = 0;
  grpc::Status status = client_->Plan(
      SmallCityPlan(kEndlessPlanMs),
      [&](const v1::PlanUpdate& u) {
        ++updates;
        EXPECT_FALSE(u.final());
        return false;  // cancel after the first update
      },
      kPatience);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::CANCELLED);
  EXPECT_EQ(updates, 1);
  // The ten-minute plan stopped: its slot is free again.
  EXPECT_TRUE(SlotFreesWithin(kPatience));
  // The server logs a plan when gRPC is done with it, which may be after the
  // client has moved on: stop the server (it exits once every call is done),
  // then read its log. With no call open it exits at once, long before its
  // grace period ends, even though this client is still connected; a call
  // gRPC never finished (a cancelled plan whose last write failed used to
  // be one) would hold it for the whole grace period.
  server_->Signal(SIGTERM);
  ASSERT_EQ(server_->Wait(kPatience), std::optional<int>(0));
  const std::string log = server_->Stderr();
  EXPECT_THAT(log, HasSubstr("\"method\":\"PlanTrajectory\",\"code\":\"CANCELLED\""));
  // By the server's own clock the call lasted far less than the plan's
  // budget: the cancellation ended it.
  const double call_ms = LoggedCallMs(log, "CANCELLED");
  EXPECT_GE(call_ms, 0.0) << log;
  EXPECT_LT(call_ms, absl::ToDoubleMilliseconds(kPatience)) << log;
}

TEST_F(CancellationTest, StopsAtOnceWhenNoCallIsOpenThoughClientsAreConnected) {
  // An idle, connected client: its channel is not polled, so it would
  // acknowledge the server's GOAWAY only seconds later; the server does not
  // wait for that once its calls are done.
  v1::EvaluateRiskResponse response;
  ASSERT_TRUE(client_->EvaluateRisk(SmallCityPolyline(), &response).ok());
  ASSERT_TRUE(RunPlan(*client_, SmallCityPlan(0, 1), kPatience).status.ok());
  server_->Signal(SIGTERM);
  // Well within the two-minute grace period.
  ASSERT_EQ(server_->Wait(kPatience), std::optional<int>(0));
  EXPECT_THAT(server_->Stderr(), HasSubstr("\"event\":\"stopped\""));
}

TEST_F(CancellationTest, DeadlineStopsThePlanAndFreesTheSlotPromptly) {
  const absl::Time start = absl::Now();
  PlanOutcome plan = RunPlan(*client_, SmallCityPlan(kEndlessPlanMs), absl::Milliseconds(400));
  EXPECT_EQ(plan.status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  // Never before the deadline (a loaded machine only makes it later).
  EXPECT_GE(absl::Now() - start, absl::Milliseconds(390));
  // Whatever came before the deadline (nothing, on a slow machine) are
  // improvements, not the end.
  for (const v1::PlanUpdate& u : plan.updates) EXPECT_FALSE(u.final());
  // The server saw the deadline and stopped the ten-minute plan.
  EXPECT_TRUE(SlotFreesWithin(kPatience));
}

TEST_F(CancellationTest, SlotIsFreeAfterANormalEnd) {
  PlanOutcome plan = RunPlan(*client_, SmallCityPlan(300), kPatience);
  ASSERT_TRUE(plan.status.ok());
  // Right after the final message: nothing to wait for (the server frees the
  // slot before it sends the final message).
  PlanOutcome next = RunPlan(*client_, SmallCityPlan(0, 1), kPatience);
  EXPECT_TRUE(next.status.ok()) << next.status.error_message();
}

}  // namespace
}  // namespace riskplan::testing
