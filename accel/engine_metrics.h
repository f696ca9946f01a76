// The RiskEngine's state as metric samples and log lines, for the server to
// export (Prometheus through prometheus-cpp, structured logs) without accel/
// knowing either. Names follow server/observability/metrics.h: riskplan_accel_*.
//
//   riskplan_accel_configurations_total{runner}      counter  runner: caller, cpu-N, fpga:HOST:PORT
//   riskplan_accel_chunks_total{runner}               counter
//   riskplan_accel_batches_total                      counter
//   riskplan_accel_requeues_total                     counter  chunks given back by boards
//   riskplan_accel_busy_seconds_total{runner}         counter  (CPU workers and boards)
//   riskplan_accel_worker_state{worker, state}        gauge    1 for the worker's state, else 0
//   riskplan_accel_worker_state_changes_total{worker} counter
//   riskplan_accel_worker_failures_total{worker}      counter  failed requests
//   riskplan_accel_worker_unsupported_total{worker}   counter  chunks left to the CPU
//   riskplan_accel_worker_taken_over_total{worker}    counter  chunks callers took back from
//                                                              the board (their stop reached)
//   riskplan_accel_blob_uploads_total{worker}         counter
//   riskplan_accel_audited_sites_total{worker}        counter  sites spot-checked on the CPU
//   riskplan_accel_audit_failures_total{worker}       counter  replies the spot check refused
//   riskplan_accel_device_cycles_total{worker}        counter  as the board reports them
//   riskplan_accel_fpga_workers_up                    gauge
//   riskplan_accel_site_cache_lookups_total{result}   counter  result: hit, miss
//   riskplan_accel_cache_bytes{cache}                 gauge    cache: site, prepared_map, blob,
//                                                              kernel_weights
//   riskplan_accel_cache_limit_bytes{cache}           gauge    the bound of each (its flag)
//
// Counters are totals since the engine started: export them as gauges, or
// as counters incremented by the difference from the last export.
#ifndef RISKPLAN_ACCEL_ENGINE_METRICS_H_
#define RISKPLAN_ACCEL_ENGINE_METRICS_H_

#include <string>
#include <utility>
#include <vector>

#include "accel/fpga_worker.h"
#include "accel/risk_engine.h"

namespace riskplan::accel {

struct MetricSample {
  enum class Type { kCounter, kGauge };
  std::string name;
  Type type = Type::kGauge;
  std::vector<std::pair<std::string, std::string>> labels;
  double value = 0.0;
};

std::vector<MetricSample> EngineMetrics(const RiskEngineStats& stats);

// One JSON object for a state change, e.g.
//   {"worker":"fpga:10.0.0.7:7070","from":"up","to":"suspect","reason":"..."}
// (the server's LogEvent("accel_worker", ...) wraps it in its log line).
std::string WorkerEventJson(const WorkerEvent& event);

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_ENGINE_METRICS_H_
