// What riskplan-fpga-shim --device=verilator reports: HELLO's clock and the
// report it prints when it stops (the component's job cycles and every
// simulated clock of the bus, each as a time at the reported clock), with
// the component's CLOCK_HZ and with --report_clock_hz.

#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "absl/strings/numbers.h"
#include "accel/risk_engine.h"
#include "bench/demo_city_configs.h"
#include "gtest/gtest.h"
#include "tests/accel/accel_test_util.h"

namespace riskplan::accel {
namespace {

struct ShimRun {
  uint64_t hello_clock_hz = 0;
  int exit_status = -1;
  std::string report;  // the shim's stderr
};

// Starts the shim with `args`, evaluates `configs` through it (every batch
// on the board), stops it with SIGTERM and returns what it said. With
// `expect_up` false the shim is expected to refuse its flags and exit.
ShimRun RunShim(const std::vector<std::string>& args, const std::vector<Pose>& configs,
                bool expect_up = true) {
  ShimRun run;
  std::unique_ptr<testing::ShimProcess> shim =
      testing::ShimProcess::Launch(args, "127.0.0.1:0", /*capture_stderr=*/true);
  if (shim == nullptr) {
    ADD_FAILURE() << "riskplan-fpga-shim could not be started";
    return run;
  }
  if (!shim->endpoint().empty()) {
    std::unique_ptr<RiskEngine> engine = testing::BoardOnlyEngine(shim->endpoint());
    if (engine != nullptr) {
      std::unique_ptr<RiskEvaluator> evaluator = engine->NewEvaluator();
      std::vector<ConfigurationRisk> risks(configs.size());
      EXPECT_TRUE(evaluator->EvaluateBatch(*testing::SmallCity(), configs, risks).ok());
      run.hello_clock_hz = engine->Stats().fpga[0].hello.clock_hz;
    }
  } else if (expect_up) {
    ADD_FAILURE() << "riskplan-fpga-shim did not come up: " << shim->Stderr();
  }
  run.exit_status = shim->Terminate();
  run.report = shim->Stderr();
  return run;
}

// The count after `label` in the report ("<label> N cycles = ...").
uint64_t CountAfter(const std::string& report, const std::string& label) {
  const size_t at = report.find(label + " ");
  if (at == std::string::npos) return 0;
  const size_t start = at + label.size() + 1;
  uint64_t count = 0;
  if (!absl::SimpleAtoi(report.substr(start, report.find(' ', start) - start), &count)) return 0;
  return count;
}

std::vector<Pose> Leg() {
  // 240 samples 5 m apart, 100 m above ground, across the small city.
  std::vector<Pose> configs;
  for (int s = 0; s < 240; ++s) {
    configs.push_back(
        bench::At100mAgl(*testing::SmallCity(), 600.0 + 5.0 * s, 900.0 + 3.0 * s, 0.54));
  }
  return configs;
}

constexpr char kJobs[] = "jobs (START to DONE)";
constexpr char kBus[] = "bus (every simulated clock, CSR accesses included)";

TEST(ShimReportTest, ReportsJobAndBusCyclesAtTheComponentsClock) {
  const ShimRun run = RunShim({"--device=verilator"}, Leg());
  EXPECT_EQ(run.exit_status, 0) << run.report;
  EXPECT_EQ(run.hello_clock_hz, 100'000'000u);
  const uint64_t jobs = CountAfter(run.report, kJobs), bus = CountAfter(run.report, kBus);
  EXPECT_GT(jobs, 0u) << run.report;
  // The bus's clocks hold the jobs' and the CSR traffic around them.
  EXPECT_GT(bus, jobs) << run.report;
  EXPECT_NE(run.report.find("times reported at 100 MHz"), std::string::npos) << run.report;
  EXPECT_NE(run.report.find(" ms at 100 MHz"), std::string::npos) << run.report;
  std::cout << run.report;
}

TEST(ShimReportTest, ReportClockHzSetsTheClockOfHelloAndTheReport) {
  const ShimRun run = RunShim({"--device=verilator", "--report_clock_hz=50e6"}, Leg());
  EXPECT_EQ(run.exit_status, 0) << run.report;
  EXPECT_EQ(run.hello_clock_hz, 50'000'000u);
  const uint64_t jobs = CountAfter(run.report, kJobs);
  ASSERT_GT(jobs, 0u) << run.report;
  // "<jobs> cycles = <jobs / 50e3> ms at 50 MHz".
  std::ostringstream want;
  want << kJobs << " " << jobs << " cycles = " << 1e3 * static_cast<double>(jobs) / 50e6
       << " ms at 50 MHz";
  EXPECT_NE(run.report.find(want.str()), std::string::npos) << run.report;
  EXPECT_GT(CountAfter(run.report, kBus), jobs) << run.report;
  std::cout << run.report;
}

TEST(ShimReportTest, RefusesAClockThatIsNotOne) {
  const ShimRun run = RunShim({"--device=verilator", "--report_clock_hz=-1"}, {}, false);
  EXPECT_EQ(run.exit_status, 2);
  EXPECT_NE(run.report.find("--report_clock_hz"), std::string::npos) << run.report;
}

}  // namespace
}  // namespace riskplan::accel
