// The server with the accelerator engine behind its plans and evaluations:
// through CPU workers (--cpu_workers) the results must be bit for bit those of
// a server without the engine; through an FPGA shim (--fpga_shims) within the
// board format's bound; in both cases the engine's work shows in its metrics.
#include <signal.h>

#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/integration/requests.h"
#include "tests/integration/server_process.h"

namespace riskplan::testing {
namespace {

using ::testing::AnyOf;
using ::testing::Contains;
using ::testing::HasSubstr;

TEST(AccelEngineTest, PlansAndEvaluationsThroughCpuWorkersMatchTheDirectPath) {
  auto plain = ServerProcess::Start();
  ASSERT_TRUE(plain.ok()) << plain.status();
  auto with_engine = ServerProcess::Start(
      {"--cpu_workers=2", "--accel_caller_runs=false", "--metrics_listen=127.0.0.1:0"});
  ASSERT_TRUE(with_engine.ok()) << with_engine.status();
  const std::string log = (*with_engine)->Stderr();
  EXPECT_THAT(log, HasSubstr("\"event\":\"accel_engine\""));
  // The metrics address is logged before the readiness line.
  const std::string metrics_address = MetricsAddress(log);
  ASSERT_FALSE(metrics_address.empty()) << log;

  client::RiskplanClient a((*plain)->Channel());
  client::RiskplanClient b((*with_engine)->Channel());
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
  for (int i = 0; i < r1.samples_size(); ++i) {
    ASSERT_EQ(r1.samples(i).risk(), r2.samples(i).risk()) << "sample " << i;
  }

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

// The worker state changes the server logged ("accel_worker" events, whose
// detail is accel::WorkerEventJson), as "worker from->to".
std::vector<std::string> WorkerTransitions(const std::string& log) {
  std::vector<std::string> out;
  std::istringstream lines(log);
  for (std::string line; std::getline(lines, line);) {
    const nlohmann::json entry = nlohmann::json::parse(line, nullptr, /*allow_exceptions=*/false);
    if (!entry.is_object() || entry.value("event", "") != "accel_worker") continue;
    const nlohmann::json e =
        nlohmann::json::parse(entry.value("detail", ""), nullptr, /*allow_exceptions=*/false);
    if (!e.is_object()) continue;
    out.push_back(e.value("worker", "") + " " + e.value("from", "") + "->" + e.value("to", ""));
  }
  return out;
}

// The whole FPGA path end to end: the real server with --fpga_shims, the real
// riskplan-fpga-shim (model backend, the board's number format), the real
// client. Every risk batch goes to the board (no CPU workers, callers do not
// compute while it is up); the board's worker shows in the log and the
// metrics; when the shim is killed, requests are still answered, by the CPU.
TEST(AccelEngineTest, PlansAndEvaluationsThroughAnFpgaShim) {
  auto shim = ServerProcess::StartShim({"--device=model", "--format=board"});
  ASSERT_TRUE(shim.ok()) << shim.status();
  const std::string worker = "fpga:" + (*shim)->address();
  auto plain = ServerProcess::Start();
  ASSERT_TRUE(plain.ok()) << plain.status();
  auto server = ServerProcess::Start({"--fpga_shims=" + (*shim)->address(), "--cpu_workers=0",
                                      "--accel_caller_runs=false", "--metrics_listen=127.0.0.1:0"});
  ASSERT_TRUE(server.ok()) << server.status();
  const std::string metrics_address = MetricsAddress((*server)->Stderr());
  ASSERT_FALSE(metrics_address.empty()) << (*server)->Stderr();
  const std::string up = "riskplan_accel_worker_state{state=\"up\",worker=\"" + worker + "\"}";
  const auto metrics = [&] {
    absl::StatusOr<std::string> text = HttpGet(metrics_address, "/metrics");
    EXPECT_TRUE(text.ok()) << text.status();
    return text.ok() ? *text : std::string();
  };
  // The worker probes the board (handshake, known-answer batch) first.
  const absl::Time deadline = absl::Now() + absl::Seconds(20);
  while (MetricValue(metrics(), up) != 1.0 && absl::Now() < deadline) {
    absl::SleepFor(absl::Milliseconds(20));
  }
  ASSERT_EQ(MetricValue(metrics(), up), 1.0) << metrics();
  EXPECT_THAT(WorkerTransitions((*server)->Stderr()), Contains(worker + " probing->up"));

  client::RiskplanClient a((*plain)->Channel());
  client::RiskplanClient b((*server)->Channel());
  v1::EvaluateRiskRequest eval = SmallCityPolyline();
  eval.set_include_samples(true);
  v1::EvaluateRiskResponse exact;
  v1::EvaluateRiskResponse board;
  ASSERT_TRUE(a.EvaluateRisk(eval, &exact).ok());
  ASSERT_TRUE(b.EvaluateRisk(eval, &board).ok());
  // Within the board format's bound (docs/accel.md), and not the CPU's bits.
  EXPECT_NEAR(board.risk(), exact.risk(), 1e-5 * exact.risk());
  EXPECT_NE(board.risk(), exact.risk());
  ASSERT_EQ(board.samples_size(), exact.samples_size());
  for (int i = 0; i < exact.samples_size(); ++i) {
    ASSERT_NEAR(board.samples(i).risk(), exact.samples(i).risk(), 1e-5 * exact.samples(i).risk())
        << "sample " << i;
  }
  // A plan on an iteration budget: no comparison of this plan is as close as
  // the board's rounding (tests/accel/plan_through_shim_test.cc argues why
  // that decides it), so its trajectory is the CPU path's.
  const v1::PlanRequest request = SmallCityPlan(0, 300);
  PlanOutcome direct = RunPlan(a, request);
  PlanOutcome through_board = RunPlan(b, request);
  ASSERT_TRUE(direct.status.ok()) << direct.status.error_message();
  ASSERT_TRUE(through_board.status.ok()) << through_board.status.error_message();
  ASSERT_TRUE(direct.updates.back().final());
  ASSERT_TRUE(through_board.updates.back().final());
  const v1::Trajectory& t1 = direct.updates.back().trajectory();
  const v1::Trajectory& t2 = through_board.updates.back().trajectory();
  EXPECT_NEAR(t2.risk(), t1.risk(), 1e-5 * t1.risk());
  ASSERT_EQ(t1.waypoints_size(), t2.waypoints_size());
  for (int i = 0; i < t1.waypoints_size(); ++i) {
    EXPECT_EQ(t1.waypoints(i).x(), t2.waypoints(i).x()) << "waypoint " << i;
    EXPECT_EQ(t1.waypoints(i).y(), t2.waypoints(i).y()) << "waypoint " << i;
  }

  // Everything went to the board, which uploaded the map and the kernels
  // once, and passed its spot checks.
  std::string text = metrics();
  EXPECT_EQ(MetricValue(text, "riskplan_accel_configurations_total{runner=\"caller\"}"), 0.0);
  EXPECT_EQ(MetricValue(text, "riskplan_accel_configurations_total{runner=\"" + worker + "\"}"),
            static_cast<double>(board.samples_size() +
                                through_board.updates.back().configurations_evaluated()));
  EXPECT_EQ(MetricValue(text, "riskplan_accel_blob_uploads_total{worker=\"" + worker + "\"}"), 2.0);
  EXPECT_GT(MetricValue(text, "riskplan_accel_audited_sites_total{worker=\"" + worker + "\"}"),
            0.0);
  EXPECT_EQ(MetricValue(text, "riskplan_accel_audit_failures_total{worker=\"" + worker + "\"}"),
            0.0);
  EXPECT_GT(MetricValue(text, "riskplan_accel_cache_bytes{cache=\"blob\"}"), 0.0);
  EXPECT_EQ(MetricValue(text, "riskplan_accel_cache_limit_bytes{cache=\"blob\"}"),
            256.0 * 1024 * 1024);

  // The board goes away: the next evaluation is answered all the same, by
  // the CPU, exactly; the worker leaves "up" in the metrics and the log.
  (*shim)->Signal(SIGKILL);
  (*shim)->Wait(absl::Seconds(10));  // reaps it (nullopt: it died of the signal)
  v1::EvaluateRiskResponse after;
  ASSERT_TRUE(b.EvaluateRisk(eval, &after).ok());
  EXPECT_EQ(after.risk(), exact.risk());
  const absl::Time down_deadline = absl::Now() + absl::Seconds(20);
  while (MetricValue(metrics(), up) != 0.0 && absl::Now() < down_deadline) {
    absl::SleepFor(absl::Milliseconds(20));
  }
  text = metrics();
  EXPECT_EQ(MetricValue(text, up), 0.0) << text;
  EXPECT_EQ(MetricValue(text, "riskplan_accel_fpga_workers_up"), 0.0);
  EXPECT_THAT(WorkerTransitions((*server)->Stderr()),
              Contains(AnyOf(worker + " up->suspect", worker + " up->down")));
}

TEST(AccelEngineTest, CacheFlagsAreListedAndChecked) {
  const std::string binary = absl::StrCat(RISKPLAN_BIN_DIR, "/riskplan-server");
  const CommandResult help = RunCommand(binary + " --help 2>&1");
  for (const char* flag : {"-risk_cache_mb", "-kernel_weights_cache_mb", "-prepared_map_cache_mb",
                           "-blob_cache_mb", "-model_cache_size", "-feasibility_cache_size"}) {
    EXPECT_THAT(help.output, HasSubstr(flag));
  }
  const CommandResult blob = RunCommand(binary + " --listen=127.0.0.1:0 --blob_cache_mb=-1 2>&1");
  EXPECT_EQ(blob.exit_code, 2);
  EXPECT_THAT(blob.output, HasSubstr("--blob_cache_mb must be >= 0"));
  const CommandResult prepared =
      RunCommand(binary + " --listen=127.0.0.1:0 --prepared_map_cache_mb=-5 2>&1");
  EXPECT_EQ(prepared.exit_code, 2);
  EXPECT_THAT(prepared.output, HasSubstr("--prepared_map_cache_mb must be >= 0"));
  const CommandResult checkers =
      RunCommand(binary + " --listen=127.0.0.1:0 --feasibility_cache_size=0 2>&1");
  EXPECT_EQ(checkers.exit_code, 2);
  EXPECT_THAT(checkers.output, HasSubstr("--feasibility_cache_size must be >= 1"));
}

}  // namespace
}  // namespace riskplan::testing
