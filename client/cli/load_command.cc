// `riskplan load`: calls of one RPC under a closed- or open-loop load for a
// while, with progress every second, a latency report and, with --ceiling,
// the same load of Ping for comparison (client/load/load_generator.h).
#include <cstdio>
#include <fstream>
#include <optional>
#include <string>

#include "absl/strings/str_format.h"
#include "client/cli/command_support.h"
#include "client/cli/commands.h"
#include "client/cli/fleet_file.h"
#include "client/cli/option_requests.h"
#include "client/load/load_generator.h"

namespace riskplan::client {
namespace {

// The RPC of --rpc and its request, built from the same flags as the
// command of that name.
absl::Status SetLoadRpc(const CliOptions& o, LoadOptions* load) {
  if (o.rpc == "eval") {
    load->rpc = LoadRpc::kEvaluateRisk;
    absl::StatusOr<v1::EvaluateRiskRequest> request = EvalRequestFromOptions(o);
    if (!request.ok()) return request.status();
    load->eval_request = *request;
  } else if (o.rpc == "plan") {
    load->rpc = LoadRpc::kPlanTrajectory;
    absl::StatusOr<v1::PlanRequest> request = PlanRequestFromOptions(o);
    if (!request.ok()) return request.status();
    load->plan_request = *request;
  } else if (o.rpc == "fleet") {
    load->rpc = LoadRpc::kPlanFleet;
    if (o.missions.empty()) {
      return absl::InvalidArgumentError("--rpc=fleet needs --missions=FILE.json");
    }
    absl::StatusOr<v1::FleetRequest> request = ReadMissionsFile(o.missions, o);
    if (!request.ok()) return request.status();
    load->fleet_request = *request;
  } else if (o.rpc == "ping") {
    load->rpc = LoadRpc::kPing;
  } else if (o.rpc == "connect") {
    if (o.mode != "closed") {
      return absl::InvalidArgumentError("--rpc=connect runs in closed loop only");
    }
    load->rpc = LoadRpc::kConnect;
    load->new_channel = [&o] {
      grpc::ChannelArguments own;
      own.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
      // The files were read once already (main), so this cannot fail.
      return *MakeChannel(o.server, o.connection, own);
    };
  } else {
    return absl::InvalidArgumentError(
        absl::StrFormat("--rpc=%s: must be eval, plan, fleet, ping or connect", o.rpc));
  }
  return absl::OkStatus();
}

// The load of the flags, checked before any call; errors name the flags.
absl::StatusOr<LoadOptions> LoadOptionsFrom(const CliOptions& o) {
  LoadOptions load;
  if (absl::Status s = SetLoadRpc(o, &load); !s.ok()) return s;
  if (o.mode != "closed" && o.mode != "open") {
    return absl::InvalidArgumentError(absl::StrFormat("--mode=%s: must be closed or open", o.mode));
  }
  load.mode = o.mode == "closed" ? LoadMode::kClosed : LoadMode::kOpen;
  // Written as !(x > 0) so that NaN is refused too.
  if (o.concurrency < 1 || !(o.rate > 0) || !(o.duration_s > 0) || o.max_outstanding < 1) {
    return absl::InvalidArgumentError(
        "--concurrency, --rate, --duration_s and --max_outstanding must be > 0");
  }
  load.concurrency = o.concurrency;
  load.rate_per_s = o.rate;
  load.duration = absl::Seconds(o.duration_s);
  load.timeout = TimeoutOr(o, absl::Seconds(30));
  load.max_outstanding = o.max_outstanding;
  return load;
}

void PrintProgress(const LoadProgress& p) {
  std::printf(
      "  t=%6.1fs sent %8d done %8d errors %6d in flight %5d | %9.1f calls/s, p50 %8.3f "
      "ms, p99 %8.3f ms\n",
      p.elapsed_s, static_cast<int>(p.sent), static_cast<int>(p.completed),
      static_cast<int>(p.errors), static_cast<int>(p.outstanding), p.interval_rps,
      p.interval_p50_s * 1e3, p.interval_p99_s * 1e3);
  std::fflush(stdout);
}

}  // namespace

int RunLoad(const CliOptions& o, RiskplanClient& client) {
  absl::StatusOr<LoadOptions> load = LoadOptionsFrom(o);
  if (!load.ok()) return Usage(std::string(load.status().message()));
  // The ceiling is Ping, a call that does nothing, under the same load: what
  // the transport, gRPC and the server's threads cost alone. The ratios
  // against it show how much the RPC's own work costs beyond that.
  std::optional<LoadReport> ceiling;
  if (o.ceiling && load->rpc != LoadRpc::kPing) {
    LoadOptions ping = *load;
    ping.rpc = LoadRpc::kPing;
    std::printf("load: no-op ceiling (Ping), %s loop, %.1f s\n", o.mode.c_str(), o.duration_s);
    ceiling = RunLoad(client.channel(), ping, PrintProgress);
  }
  std::printf("load: %s, %s loop, %.1f s\n", LoadRpcName(load->rpc).c_str(), o.mode.c_str(),
              o.duration_s);
  LoadReport report = RunLoad(client.channel(), *load, PrintProgress);
  const LoadReport* ceiling_ptr = ceiling.has_value() ? &*ceiling : nullptr;
  std::printf("\n%s", LoadReportText(report, ceiling_ptr).c_str());
  if (!o.report_json.empty()) {
    std::ofstream out(o.report_json);
    out << LoadReportJson(report, ceiling_ptr);
    if (!out) return Usage(absl::StrFormat("cannot write --report_json=%s", o.report_json));
    std::printf("report: %s\n", o.report_json.c_str());
  }
  return 0;
}

}  // namespace riskplan::client
