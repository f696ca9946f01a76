// The load generator behind `riskplan load`.
//
// Closed loop: `concurrency` callers, each sending its next call as soon as
// the previous one ends; latency is measured from each call's send.
// Open loop: calls sent at a fixed rate whatever the server does; latency is
// measured from each call's *intended* send time, so a stalled server or a
// lagging sender shows up in the latency instead of quietly lowering the
// offered load (no coordinated omission).
//
// Both report throughput, latency percentiles and calls by status code.
#ifndef RISKPLAN_CLIENT_LOAD_LOAD_GENERATOR_H_
#define RISKPLAN_CLIENT_LOAD_LOAD_GENERATOR_H_

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/time/time.h"
#include "client/load/latency_histogram.h"
#include "grpcpp/grpcpp.h"
#include "riskplan/v1/planner.grpc.pb.h"

namespace riskplan::client {

// kConnect: every call opens a new connection (TCP, and the TLS handshake
// when TLS is on) and sends one Ping on it: the cost of connecting.
// kPlanFleet: one call is one whole fleet (its latency: until every mission
// has ended; plan_updates counts its FleetUpdates).
enum class LoadRpc { kEvaluateRisk, kPlanTrajectory, kPing, kConnect, kPlanFleet };
enum class LoadMode { kClosed, kOpen };

// "EvaluateRisk", "PlanTrajectory", "Ping", "Connect", "PlanFleet"; "closed",
// "open".
std::string LoadRpcName(LoadRpc rpc);
std::string LoadModeName(LoadMode mode);

struct LoadOptions {
  LoadRpc rpc = LoadRpc::kEvaluateRisk;
  LoadMode mode = LoadMode::kClosed;
  int concurrency = 8;        // closed loop: callers
  double rate_per_s = 100.0;  // open loop: calls per second
  absl::Duration duration = absl::Seconds(10);
  absl::Duration timeout = absl::Seconds(30);  // deadline of each call
  // Open loop: calls in flight at most; a call due beyond it is not sent and
  // counts as CLIENT_OVERLOADED (the client, not the server, is saturated).
  int max_outstanding = 10000;
  v1::EvaluateRiskRequest eval_request;  // for kEvaluateRisk
  v1::PlanRequest plan_request;          // for kPlanTrajectory
  v1::FleetRequest fleet_request;        // for kPlanFleet
  // For kConnect (closed loop only): a channel that shares no connection
  // with any other.
  std::function<std::shared_ptr<grpc::Channel>()> new_channel;
};

// Calls that a code name counts but that never reached the server.
inline constexpr char kClientOverloaded[] = "CLIENT_OVERLOADED";
// The replica of a completed call that reached none (no peer).
inline constexpr char kNoReplica[] = "(none)";

struct LoadReport {
  LoadOptions options;
  double elapsed_s = 0.0;  // first send to last completion
  int64_t sent = 0;
  int64_t completed = 0;
  std::map<std::string, int64_t> codes;  // status code name -> calls
  // By the replica that answered (the call's peer, "ipv4:127.0.0.1:50051";
  // kNoReplica for a call that reached none), its calls by code: with a
  // target of several addresses, how the load was shared.
  std::map<std::string, std::map<std::string, int64_t>> replicas;
  LatencyHistogram latency;              // every completed call, whatever its code
  LatencyHistogram first_update;         // plans, fleets: time to the first streamed message
  int64_t plan_updates = 0;              // plans, fleets: messages received

  int64_t ok() const;
  int64_t errors() const { return completed - ok() + Overloaded(); }
  int64_t Overloaded() const;
  double throughput_rps() const { return elapsed_s > 0 ? completed / elapsed_s : 0.0; }
  double ok_rps() const { return elapsed_s > 0 ? ok() / elapsed_s : 0.0; }
};

// A snapshot once per second while a run lasts.
struct LoadProgress {
  double elapsed_s = 0.0;
  int64_t sent = 0;
  int64_t completed = 0;
  int64_t errors = 0;
  int64_t outstanding = 0;
  double interval_rps = 0.0;  // completions per second over the last interval
  double interval_p50_s = 0.0;
  double interval_p99_s = 0.0;
};

using LoadProgressCallback = std::function<void(const LoadProgress&)>;

// Runs one load phase against `channel`. Blocks for about options.duration,
// plus the time the last calls take to end.
// REQUIRES: options.rate_per_s > 0 and finite when options.mode is kOpen.
LoadReport RunLoad(const std::shared_ptr<grpc::Channel>& channel, const LoadOptions& options,
                   const LoadProgressCallback& progress);

// Human-readable report; with `ceiling` (a Ping run with the same settings),
// also the ratios of throughput and latency against it.
std::string LoadReportText(const LoadReport& report, const LoadReport* ceiling);

// The same as JSON (see docs/benchmarks.md for the fields).
std::string LoadReportJson(const LoadReport& report, const LoadReport* ceiling);

}  // namespace riskplan::client

#endif  // RISKPLAN_CLIENT_LOAD_LOAD_GENERATOR_H_
