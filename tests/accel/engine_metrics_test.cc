// The engine's metric samples and worker-event log lines.
#include "accel/engine_metrics.h"

#include "gtest/gtest.h"

namespace riskplan::accel {
namespace {

const MetricSample* Find(const std::vector<MetricSample>& samples, const std::string& name,
                         const std::vector<std::pair<std::string, std::string>>& labels) {
  for (const MetricSample& s : samples) {
    if (s.name == name && s.labels == labels) return &s;
  }
  return nullptr;
}

TEST(EngineMetricsTest, ReportsRunnersWorkersAndCaches) {
  RiskEngineStats stats;
  stats.batches = 3;
  stats.caller_configurations = 10;
  stats.cpu.push_back(CpuWorkerStats{"cpu-0", 2, 20, 0.5});
  FpgaWorkerStats board;
  board.name = "fpga:h:1";
  board.state = WorkerState::kSuspect;
  board.configurations = 30;
  board.failures = 1;
  board.audited = 12;
  board.audit_failures = 1;
  stats.fpga.push_back(board);
  stats.cache_hits = 7;
  stats.site_cache_bytes = 1 << 20;
  stats.blob_cache_limit_bytes = 256 << 20;
  const std::vector<MetricSample> m = EngineMetrics(stats);
  ASSERT_NE(Find(m, "riskplan_accel_configurations_total", {{"runner", "cpu-0"}}), nullptr);
  EXPECT_EQ(Find(m, "riskplan_accel_configurations_total", {{"runner", "fpga:h:1"}})->value, 30);
  EXPECT_EQ(Find(m, "riskplan_accel_configurations_total", {{"runner", "caller"}})->value, 10);
  EXPECT_EQ(
      Find(m, "riskplan_accel_worker_state", {{"worker", "fpga:h:1"}, {"state", "suspect"}})->value,
      1);
  EXPECT_EQ(
      Find(m, "riskplan_accel_worker_state", {{"worker", "fpga:h:1"}, {"state", "up"}})->value, 0);
  EXPECT_EQ(Find(m, "riskplan_accel_fpga_workers_up", {})->value, 0);
  EXPECT_EQ(Find(m, "riskplan_accel_site_cache_lookups_total", {{"result", "hit"}})->value, 7);
  EXPECT_EQ(Find(m, "riskplan_accel_cache_bytes", {{"cache", "site"}})->value, 1 << 20);
  EXPECT_EQ(Find(m, "riskplan_accel_worker_failures_total", {{"worker", "fpga:h:1"}})->type,
            MetricSample::Type::kCounter);
  EXPECT_EQ(Find(m, "riskplan_accel_audited_sites_total", {{"worker", "fpga:h:1"}})->value, 12);
  EXPECT_EQ(Find(m, "riskplan_accel_audit_failures_total", {{"worker", "fpga:h:1"}})->value, 1);
  EXPECT_EQ(Find(m, "riskplan_accel_cache_limit_bytes", {{"cache", "blob"}})->value, 256 << 20);
  EXPECT_EQ(Find(m, "riskplan_accel_cache_limit_bytes", {{"cache", "site"}})->type,
            MetricSample::Type::kGauge);
}

TEST(EngineMetricsTest, EventsAsJson) {
  WorkerEvent e{"fpga:10.0.0.7:7070", WorkerState::kUp, WorkerState::kSuspect,
                "shim: \"EVAL\" deadline\n"};
  EXPECT_EQ(WorkerEventJson(e),
            "{\"worker\":\"fpga:10.0.0.7:7070\",\"from\":\"up\",\"to\":\"suspect\","
            "\"reason\":\"shim: \\\"EVAL\\\" deadline\\u000a\"}");
}

}  // namespace
}  // namespace riskplan::accel
