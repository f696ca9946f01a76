#include "server/observability/metrics.h"

#include <exception>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "server/api/status_util.h"

namespace riskplan::server {
namespace {

// first, first*factor, ... (count boundaries). Exponential, because RPC and
// plan durations span several orders of magnitude (a Ping against a plan of
// minutes) and the relative resolution is what matters.
prometheus::Histogram::BucketBoundaries Exponential(double first, double factor, int count) {
  prometheus::Histogram::BucketBoundaries b;
  double v = first;
  for (int i = 0; i < count; ++i, v *= factor) b.push_back(v);
  return b;
}

}  // namespace

ServerMetrics::ServerMetrics() : registry_(std::make_shared<prometheus::Registry>()) {
  rpcs_ = &prometheus::BuildCounter()
               .Name("riskplan_rpcs_total")
               .Help("RPCs finished, by method and status code")
               .Register(*registry_);
  rpcs_by_identity_ = &prometheus::BuildCounter()
                          .Name("riskplan_rpcs_by_identity_total")
                          .Help("RPCs finished, by caller identity (token identity or client "
                                "certificate; at most 64 values, then \"other\"), method and code")
                          .Register(*registry_);
  rpc_duration_ = &prometheus::BuildHistogram()
                       .Name("riskplan_rpc_duration_seconds")
                       .Help("Time from the start of an RPC to its status, by method")
                       .Register(*registry_);
  running_plans_ = &prometheus::BuildGauge()
                        .Name("riskplan_running_plans")
                        .Help("Plans admitted and not yet finished (queued or planning)")
                        .Register(*registry_)
                        .Add({});
  missions_in_flight_ =
      &prometheus::BuildGauge()
           .Name("riskplan_missions_in_flight")
           .Help("The replica's load for autoscaling: PlanTrajectory plans admitted and not "
                 "finished plus PlanFleet missions queued or running")
           .Register(*registry_)
           .Add({});
  plan_duration_ = &prometheus::BuildHistogram()
                        .Name("riskplan_plan_duration_seconds")
                        .Help("Planner time of finished plans, by end reason")
                        .Register(*registry_);
  plan_updates_ = &prometheus::BuildCounter()
                       .Name("riskplan_plan_updates_total")
                       .Help("Plan improvements, by kind: sent to the client or replaced unsent")
                       .Register(*registry_);
  map_memory_ = &prometheus::BuildGauge()
                     .Name("riskplan_map_memory_bytes")
                     .Help("Bytes held by each loaded map's layers")
                     .Register(*registry_);
  fleet_admitted_ = &prometheus::BuildCounter()
                         .Name("riskplan_fleet_missions_admitted_total")
                         .Help(
                             "PlanFleet missions admitted (queued to be planned or refused "
                             "one by one)")
                         .Register(*registry_)
                         .Add({});
  fleet_ended_ = &prometheus::BuildCounter()
                      .Name("riskplan_fleet_missions_ended_total")
                      .Help(
                          "PlanFleet missions ended, by outcome: completed (a final "
                          "PlanUpdate), failed (an error), cancelled (the client went)")
                      .Register(*registry_);
  fleet_missions_ = &prometheus::BuildGauge()
                         .Name("riskplan_fleet_missions")
                         .Help(
                             "PlanFleet missions admitted and not ended, by state: queued "
                             "(waiting for a plan slot) or running")
                         .Register(*registry_);
  model_builds_ = &prometheus::BuildCounter()
                       .Name("riskplan_model_cache_builds_total")
                       .Help("Risk models built for overridden model parameters")
                       .Register(*registry_)
                       .Add({});
  accept_errors_ = &prometheus::BuildCounter()
                        .Name("riskplan_accept_errors_total")
                        .Help(
                            "Connections the server could not accept (out of file descriptors "
                            "or memory); it retries, and they wait in the listen backlog")
                        .Register(*registry_)
                        .Add({});
}

ServerMetrics::~ServerMetrics() = default;

absl::StatusOr<std::string> ServerMetrics::Expose(const std::string& address) {
  // prometheus-cpp reports a failed bind by throwing (CivetWeb); the server
  // reports start-up failures as a Status and an exit code.
  try {
    exposer_ = std::make_unique<prometheus::Exposer>(address, /*num_threads=*/1);
  } catch (const std::exception& e) {
    return absl::UnavailableError(
        absl::StrFormat("--metrics_listen=%s: cannot serve metrics: %s", address, e.what()));
  }
  exposer_->RegisterCollectable(registry_);
  for (const auto& c : collectables_) exposer_->RegisterCollectable(c);
  // The bound port: the address may ask for port 0.
  const std::vector<int> ports = exposer_->GetListeningPorts();
  const std::string host = address.substr(0, address.rfind(':'));
  return absl::StrCat(host, ":", ports.empty() ? 0 : ports.front());
}

void ServerMetrics::RecordRpc(std::string_view method, grpc::StatusCode code,
                              absl::Duration duration, std::string_view identity_label) {
  rpcs_->Add({{"method", std::string(method)}, {"code", std::string(GrpcCodeName(code))}})
      .Increment();
  rpcs_by_identity_
      ->Add({{"identity", identity_label.empty() ? "anonymous" : std::string(identity_label)},
             {"method", std::string(method)},
             {"code", std::string(GrpcCodeName(code))}})
      .Increment();
  // Leaked on purpose: never destroyed, so a call recorded while the
  // process exits cannot read freed boundaries.
  static const auto* buckets =
      new prometheus::Histogram::BucketBoundaries(Exponential(0.0001, 2.0, 22));  // 100 us .. 210 s
  rpc_duration_->Add({{"method", std::string(method)}}, *buckets)
      .Observe(absl::ToDoubleSeconds(duration));
}

void ServerMetrics::RecordPlan(std::string_view end_reason, absl::Duration planner_time) {
  // 10 ms .. 655 s: past --max_plan_time_ms's default of 600 s.
  static const auto* buckets =
      new prometheus::Histogram::BucketBoundaries(Exponential(0.01, 2.0, 17));
  plan_duration_->Add({{"end_reason", std::string(end_reason)}}, *buckets)
      .Observe(absl::ToDoubleSeconds(planner_time));
}

void ServerMetrics::RecordUpdates(int64_t sent, int64_t replaced) {
  plan_updates_->Add({{"kind", "sent"}}).Increment(static_cast<double>(sent));
  plan_updates_->Add({{"kind", "replaced"}}).Increment(static_cast<double>(replaced));
}

void ServerMetrics::RecordFleetMissionsEnded(int64_t completed, int64_t failed, int64_t cancelled) {
  fleet_ended_->Add({{"outcome", "completed"}}).Increment(static_cast<double>(completed));
  fleet_ended_->Add({{"outcome", "failed"}}).Increment(static_cast<double>(failed));
  fleet_ended_->Add({{"outcome", "cancelled"}}).Increment(static_cast<double>(cancelled));
}

void ServerMetrics::PlanAdmitted(PlanKind kind) {
  running_plans_->Increment();
  if (kind != PlanKind::kTrajectory) return;
  absl::MutexLock lock(&mu_);
  ++trajectory_plans_;
  missions_in_flight_->Set(static_cast<double>(trajectory_plans_ + fleet_missions_in_flight_));
}

void ServerMetrics::PlanReleased(PlanKind kind) {
  running_plans_->Decrement();
  if (kind != PlanKind::kTrajectory) return;
  absl::MutexLock lock(&mu_);
  --trajectory_plans_;
  missions_in_flight_->Set(static_cast<double>(trajectory_plans_ + fleet_missions_in_flight_));
}

void ServerMetrics::SetFleetMissions(int64_t queued, int64_t running) {
  fleet_missions_->Add({{"state", "queued"}}).Set(static_cast<double>(queued));
  fleet_missions_->Add({{"state", "running"}}).Set(static_cast<double>(running));
  absl::MutexLock lock(&mu_);
  fleet_missions_in_flight_ = queued + running;
  missions_in_flight_->Set(static_cast<double>(trajectory_plans_ + fleet_missions_in_flight_));
}

void ServerMetrics::SetMapMemory(const std::string& map, double bytes) {
  map_memory_->Add({{"map", map}}).Set(bytes);
}

// Kept as well as registered: a collectable added before Expose() is
// registered when the exposer is created.
void ServerMetrics::AddCollectable(std::shared_ptr<prometheus::Collectable> collectable) {
  collectables_.push_back(collectable);
  if (exposer_ != nullptr) exposer_->RegisterCollectable(collectable);
}

}  // namespace riskplan::server
