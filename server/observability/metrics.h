// ServerMetrics: the server's Prometheus metrics (prometheus-cpp), optionally
// served over HTTP at /metrics.
//
//   riskplan_rpcs_total{method, code}             counter
//   riskplan_rpcs_by_identity_total{identity, method, code}
//                                                  counter (identity: at most 64 values and
//                                                  "other", "anonymous"; server/security/auth.h)
//   riskplan_rpc_duration_seconds{method}          histogram
//   riskplan_running_plans                         gauge (admitted plans, queued or planning)
//   riskplan_plan_duration_seconds{end_reason}     histogram (planner time of finished plans)
//   riskplan_plan_updates_total{kind}              counter (kind: sent, replaced)
//   riskplan_map_memory_bytes{map}                 gauge
//   riskplan_fleet_missions_admitted_total         counter (PlanFleet missions admitted)
//   riskplan_fleet_missions_ended_total{outcome}   counter (outcome: completed, with a final
//                                                  PlanUpdate; failed, with an error; cancelled,
//                                                  unreported because the client went)
//   riskplan_fleet_missions{state}                 gauge (state: queued, running)
//   riskplan_missions_in_flight                    gauge (the replica's load, what the
//                                                  HorizontalPodAutoscaler scales on:
//                                                  PlanTrajectory plans admitted and not
//                                                  finished + PlanFleet missions queued or
//                                                  running; docs/fleet.md)
//   riskplan_model_cache_builds_total              counter
//   riskplan_accept_errors_total                   counter (failed accepts, ConnectionAcceptor)
//
// Thread-safe.
#ifndef RISKPLAN_SERVER_OBSERVABILITY_METRICS_H_
#define RISKPLAN_SERVER_OBSERVABILITY_METRICS_H_

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "grpcpp/support/status_code_enum.h"
#include "prometheus/counter.h"
#include "prometheus/exposer.h"
#include "prometheus/family.h"
#include "prometheus/gauge.h"
#include "prometheus/histogram.h"
#include "prometheus/registry.h"

namespace riskplan::server {

class ServerMetrics {
 public:
  ServerMetrics();
  ~ServerMetrics();

  // Serves the metrics at http://ADDRESS/metrics (ADDRESS "host:port", port 0
  // picks one). Returns the bound "host:port", or an error when it cannot bind.
  absl::StatusOr<std::string> Expose(const std::string& address);

  // `identity_label` is Caller::label (bounded cardinality); "" counts as
  // "anonymous".
  void RecordRpc(std::string_view method, grpc::StatusCode code, absl::Duration duration,
                 std::string_view identity_label = "");
  // What holds a plan slot: a PlanTrajectory call (one mission) or a group
  // of PlanFleet missions (counted by SetFleetMissions).
  enum class PlanKind { kTrajectory, kFleetGroup };
  void PlanAdmitted(PlanKind kind);
  void PlanReleased(PlanKind kind);
  // The riskplan_running_plans gauge (for checks of the admission bookkeeping).
  double running_plans() const { return running_plans_->Value(); }
  void RecordPlan(std::string_view end_reason, absl::Duration planner_time);
  void RecordUpdates(int64_t sent, int64_t replaced);
  void SetMapMemory(const std::string& map, double bytes);
  void RecordFleetMissionsAdmitted(int64_t missions) {
    fleet_admitted_->Increment(static_cast<double>(missions));
  }
  void RecordFleetMissionsEnded(int64_t completed, int64_t failed, int64_t cancelled);
  void SetFleetMissions(int64_t queued, int64_t running);
  // The riskplan_missions_in_flight gauge.
  double missions_in_flight() const { return missions_in_flight_->Value(); }
  void RecordModelBuild() { model_builds_->Increment(); }
  void RecordAcceptError() { accept_errors_->Increment(); }

  prometheus::Registry& registry() { return *registry_; }

  // Serves `collectable` next to the registry (now, or once Expose() is
  // called). The metrics keep a reference to it.
  void AddCollectable(std::shared_ptr<prometheus::Collectable> collectable);

 private:
  std::vector<std::shared_ptr<prometheus::Collectable>> collectables_;
  std::shared_ptr<prometheus::Registry> registry_;
  std::unique_ptr<prometheus::Exposer> exposer_;
  prometheus::Family<prometheus::Counter>* rpcs_;
  prometheus::Family<prometheus::Counter>* rpcs_by_identity_;
  prometheus::Family<prometheus::Histogram>* rpc_duration_;
  prometheus::Gauge* running_plans_;
  prometheus::Family<prometheus::Histogram>* plan_duration_;
  prometheus::Family<prometheus::Counter>* plan_updates_;
  prometheus::Family<prometheus::Gauge>* map_memory_;
  prometheus::Counter* fleet_admitted_;
  prometheus::Family<prometheus::Counter>* fleet_ended_;
  prometheus::Family<prometheus::Gauge>* fleet_missions_;
  prometheus::Gauge* missions_in_flight_;
  // The two terms of missions_in_flight_, set together under mu_.
  absl::Mutex mu_;
  int64_t trajectory_plans_ ABSL_GUARDED_BY(mu_) = 0;
  int64_t fleet_missions_in_flight_ ABSL_GUARDED_BY(mu_) = 0;
  prometheus::Counter* model_builds_;
  prometheus::Counter* accept_errors_;
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_OBSERVABILITY_METRICS_H_
