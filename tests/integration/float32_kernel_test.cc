// The server with --cpu_kernel=float32: plans complete, and the risk a plan
// reports is within the float32 path's 1e-5 of the exact re-evaluation of
// its trajectory (EvaluateRisk on a server without the flag, which is
// riskplan-tool's and EvaluateTrajectory's arithmetic bit for bit).
#include <cmath>
#include <regex>
#include <string>

#include "absl/strings/str_cat.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/integration/requests.h"
#include "tests/integration/server_process.h"

namespace riskplan::testing {
namespace {

using ::testing::HasSubstr;

TEST(Float32KernelTest, PlanRiskIsWithin1e5OfTheExactReevaluation) {
  auto exact = ServerProcess::Start();
  ASSERT_TRUE(exact.ok()) << exact.status();
  auto float32 = ServerProcess::Start({"--cpu_kernel=float32", "--metrics_listen=127.0.0.1:0"});
  ASSERT_TRUE(float32.ok()) << float32.status();
  const std::string log = (*float32)->Stderr();
  EXPECT_THAT(log, HasSubstr("cpu_kernel=float32"));

  client::RiskplanClient a((*exact)->Channel());
  client::RiskplanClient b((*float32)->Channel());
  PlanOutcome plan = RunPlan(b, SmallCityPlan(0, 400));
  ASSERT_TRUE(plan.status.ok()) << plan.status.error_message();
  ASSERT_FALSE(plan.updates.empty());
  ASSERT_TRUE(plan.updates.back().final());
  const v1::Trajectory& best = plan.updates.back().trajectory();
  ASSERT_GT(best.risk(), 0.0);

  v1::EvaluateRiskRequest eval;
  eval.set_map("demo-city");
  *eval.mutable_waypoints()->mutable_poses() = best.waypoints();
  v1::EvaluateRiskResponse reference;
  grpc::Status status = a.EvaluateRisk(eval, &reference);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_TRUE(reference.admissible());
  EXPECT_NEAR(best.risk(), reference.risk(), 1e-5 * reference.risk());
  std::printf("plan risk (float32) %.17g, exact re-evaluation %.17g, relative error %.3g\n",
              best.risk(), reference.risk(), std::abs(best.risk() / reference.risk() - 1.0));

  // EvaluateRisk through the float32 kernel: the same bound, sample by sample.
  eval.set_include_samples(true);
  v1::EvaluateRiskResponse approximate;
  v1::EvaluateRiskResponse exact_samples;
  ASSERT_TRUE(b.EvaluateRisk(eval, &approximate).ok());
  ASSERT_TRUE(a.EvaluateRisk(eval, &exact_samples).ok());
  EXPECT_NEAR(approximate.risk(), reference.risk(), 1e-5 * reference.risk());
  ASSERT_EQ(approximate.samples_size(), exact_samples.samples_size());
  for (int i = 0; i < approximate.samples_size(); ++i) {
    const double want = exact_samples.samples(i).risk();
    ASSERT_NEAR(approximate.samples(i).risk(), want, 1e-5 * want) << "sample " << i;
  }

  // The float32 weights are a bounded cache, reported with the others.
  std::smatch match;
  ASSERT_TRUE(std::regex_search(
      log, match,
      std::regex("\\{[^\n]*\"detail\":\"([0-9.:]+)\"[^\n]*\"event\":\"metrics_listening\"|"
                 "\"event\":\"metrics_listening\",\"detail\":\"([0-9.:]+)\"")))
      << log;
  const std::string metrics_address = match[1].matched ? match[1] : match[2];
  absl::StatusOr<std::string> text = HttpGet(metrics_address, "/metrics");
  ASSERT_TRUE(text.ok()) << text.status();
  std::smatch bytes;
  ASSERT_TRUE(std::regex_search(
      *text, bytes,
      std::regex("riskplan_accel_cache_bytes\\{cache=\"kernel_weights\"\\} ([0-9.e+]+)")))
      << *text;
  EXPECT_GT(std::stod(bytes[1]), 0.0);
}

TEST(Float32KernelTest, FlagIsListedAndChecked) {
  const std::string binary = absl::StrCat(RISKPLAN_BIN_DIR, "/riskplan-server");
  const CommandResult help = RunCommand(binary + " --help 2>&1");
  EXPECT_THAT(help.output, HasSubstr("-cpu_kernel"));
  EXPECT_THAT(help.output, HasSubstr("float32"));
  const CommandResult bad = RunCommand(binary + " --listen=127.0.0.1:0 --cpu_kernel=float16 2>&1");
  EXPECT_THAT(bad.output, HasSubstr("--cpu_kernel=float16: must be exact or float32"));
  EXPECT_EQ(bad.exit_code, 2);
}

}  // namespace
}  // namespace riskplan::testing
