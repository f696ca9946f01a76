// Structured logs: one JSON line per finished RPC on stderr, e.g.
//   {"ts":"2024-05-01T10:00:00.123Z","event":"rpc","method":"EvaluateRisk",
//    "code":"OK","duration_ms":1.84,"peer":"ipv4:127.0.0.1:51234","identity":"ground-1",
//    "map":"demo-city"}
// plus "detail" (the status message, or a plan's end reason and counts).
// Lines are written whole (one write per line) so concurrent RPCs never
// interleave. Thread-safe.
#ifndef RISKPLAN_SERVER_OBSERVABILITY_RPC_LOG_H_
#define RISKPLAN_SERVER_OBSERVABILITY_RPC_LOG_H_

#include <string>
#include <string_view>

#include "absl/time/time.h"
#include "grpcpp/support/status.h"

namespace riskplan::server {

struct RpcLogRecord {
  std::string_view method;
  grpc::Status status;
  absl::Duration duration;
  std::string peer;
  std::string identity;  // the caller (server/security/auth.h Caller); may be empty
  std::string map;     // may be empty
  std::string detail;  // may be empty
};

// Turns RPC logging on or off (on by default).
void SetRpcLogEnabled(bool enabled);

void LogRpc(const RpcLogRecord& record);

// A server event that is not an RPC: {"ts":...,"event":EVENT,"detail":DETAIL}.
void LogEvent(std::string_view event, std::string_view detail);

// Routes Protobuf's own messages into this log, as events "protobuf" whose
// detail is "LEVEL FILE:LINE: MESSAGE", instead of Protobuf's plain lines on
// stderr: a request with a string field that is not UTF-8 makes Protobuf log
// while it parses, and that line would otherwise break the one-JSON-object-
// per-line log, once per such request. Call once at start-up.
void RouteProtobufLogs();

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_OBSERVABILITY_RPC_LOG_H_
