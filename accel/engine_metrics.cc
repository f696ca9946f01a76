#include "accel/engine_metrics.h"

#include "absl/strings/str_cat.h"

namespace riskplan::accel {
namespace {

// JSON string escaping for the few characters a reason may contain.
std::string Quoted(absl::string_view text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      absl::StrAppend(&out, "\\u00", c < 0x10 ? "0" : "", absl::Hex(c));
    } else {
      out += c;
    }
  }
  return out + "\"";
}

}  // namespace

std::vector<MetricSample> EngineMetrics(const RiskEngineStats& stats) {
  using Type = MetricSample::Type;
  std::vector<MetricSample> out;
  const auto add = [&](std::string name, Type type,
                       std::vector<std::pair<std::string, std::string>> labels, double value) {
    out.push_back(MetricSample{std::move(name), type, std::move(labels), value});
  };
  add("riskplan_accel_batches_total", Type::kCounter, {}, stats.batches);
  add("riskplan_accel_requeues_total", Type::kCounter, {}, stats.requeues);
  add("riskplan_accel_configurations_total", Type::kCounter, {{"runner", "caller"}},
      stats.caller_configurations);
  add("riskplan_accel_chunks_total", Type::kCounter, {{"runner", "caller"}}, stats.caller_chunks);
  for (const CpuWorkerStats& w : stats.cpu) {
    add("riskplan_accel_configurations_total", Type::kCounter, {{"runner", w.name}},
        w.configurations);
    add("riskplan_accel_chunks_total", Type::kCounter, {{"runner", w.name}}, w.chunks);
    add("riskplan_accel_busy_seconds_total", Type::kCounter, {{"runner", w.name}}, w.busy_seconds);
  }
  int up = 0;
  for (const FpgaWorkerStats& w : stats.fpga) {
    add("riskplan_accel_configurations_total", Type::kCounter, {{"runner", w.name}},
        w.configurations);
    add("riskplan_accel_chunks_total", Type::kCounter, {{"runner", w.name}}, w.chunks);
    add("riskplan_accel_busy_seconds_total", Type::kCounter, {{"runner", w.name}}, w.busy_seconds);
    for (WorkerState s :
         {WorkerState::kUp, WorkerState::kSuspect, WorkerState::kDown, WorkerState::kProbing}) {
      add("riskplan_accel_worker_state", Type::kGauge,
          {{"worker", w.name}, {"state", std::string(WorkerStateName(s))}}, w.state == s ? 1 : 0);
    }
    add("riskplan_accel_worker_state_changes_total", Type::kCounter, {{"worker", w.name}},
        w.state_changes);
    add("riskplan_accel_worker_failures_total", Type::kCounter, {{"worker", w.name}}, w.failures);
    add("riskplan_accel_worker_unsupported_total", Type::kCounter, {{"worker", w.name}},
        w.unsupported);
    add("riskplan_accel_worker_taken_over_total", Type::kCounter, {{"worker", w.name}},
        w.taken_over);
    add("riskplan_accel_blob_uploads_total", Type::kCounter, {{"worker", w.name}}, w.uploads);
    add("riskplan_accel_audited_sites_total", Type::kCounter, {{"worker", w.name}}, w.audited);
    add("riskplan_accel_audit_failures_total", Type::kCounter, {{"worker", w.name}},
        w.audit_failures);
    add("riskplan_accel_device_cycles_total", Type::kCounter, {{"worker", w.name}},
        w.device_cycles);
    up += w.state == WorkerState::kUp;
  }
  add("riskplan_accel_fpga_workers_up", Type::kGauge, {}, up);
  add("riskplan_accel_site_cache_lookups_total", Type::kCounter, {{"result", "hit"}},
      stats.cache_hits);
  add("riskplan_accel_site_cache_lookups_total", Type::kCounter, {{"result", "miss"}},
      stats.cache_misses);
  add("riskplan_accel_cache_bytes", Type::kGauge, {{"cache", "site"}}, stats.site_cache_bytes);
  add("riskplan_accel_cache_bytes", Type::kGauge, {{"cache", "prepared_map"}},
      stats.prepared_map_bytes);
  add("riskplan_accel_cache_bytes", Type::kGauge, {{"cache", "blob"}}, stats.blob_cache_bytes);
  add("riskplan_accel_cache_bytes", Type::kGauge, {{"cache", "kernel_weights"}},
      stats.kernel_weights_bytes);
  add("riskplan_accel_cache_limit_bytes", Type::kGauge, {{"cache", "site"}},
      stats.site_cache_limit_bytes);
  add("riskplan_accel_cache_limit_bytes", Type::kGauge, {{"cache", "prepared_map"}},
      stats.prepared_map_limit_bytes);
  add("riskplan_accel_cache_limit_bytes", Type::kGauge, {{"cache", "blob"}},
      stats.blob_cache_limit_bytes);
  add("riskplan_accel_cache_limit_bytes", Type::kGauge, {{"cache", "kernel_weights"}},
      stats.kernel_weights_limit_bytes);
  return out;
}

std::string WorkerEventJson(const WorkerEvent& e) {
  return absl::StrCat(
      "{\"worker\":", Quoted(e.worker), ",\"from\":", Quoted(WorkerStateName(e.from)),
      ",\"to\":", Quoted(WorkerStateName(e.to)), ",\"reason\":", Quoted(e.reason), "}");
}

}  // namespace riskplan::accel
