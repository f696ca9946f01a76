#include "server/observability/rpc_log.h"

#include <unistd.h>

#include <atomic>

#include "absl/strings/str_format.h"
#include "absl/time/clock.h"
#include "google/protobuf/stubs/logging.h"
#include "nlohmann/json.hpp"
#include "server/api/status_util.h"

namespace riskplan::server {
namespace {

std::atomic<bool> rpc_log_enabled{true};

void WriteLine(nlohmann::ordered_json& line) {
  // `replace`: a peer address or status message that is not valid UTF-8 is
  // logged with replacement characters instead of throwing from a log call.
  std::string text = line.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
  text.push_back('\n');
  // One write(2) per line: atomic with respect to other lines for pipes and
  // regular files at these sizes, and no stdio lock to contend on.
  size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(STDERR_FILENO, text.data() + done, text.size() - done);
    // A closed or broken stderr loses the line; the RPC must not fail or
    // spin because of its log.
    if (n <= 0) return;
    done += static_cast<size_t>(n);
  }
}

// UTC with milliseconds: lines from several replicas sort together.
std::string Timestamp() {
  return absl::FormatTime("%Y-%m-%dT%H:%M:%E3SZ", absl::Now(), absl::UTCTimeZone());
}

}  // namespace

void SetRpcLogEnabled(bool enabled) { rpc_log_enabled.store(enabled); }

void LogRpc(const RpcLogRecord& record) {
  // Relaxed: the flag is set once at start-up, before any RPC, and a stale
  // read could only log or skip one line.
  if (!rpc_log_enabled.load(std::memory_order_relaxed)) return;
  nlohmann::ordered_json line = {
      {"ts", Timestamp()},
      {"event", "rpc"},
      {"method", record.method},
      {"code", GrpcCodeName(record.status.error_code())},
      {"duration_ms", absl::ToDoubleMilliseconds(record.duration)},
      {"peer", record.peer},
  };
  // Never a token: the identity the token file gives it, or a certificate's
  // subject.
  if (!record.identity.empty()) line["identity"] = record.identity;
  if (!record.map.empty()) line["map"] = record.map;
  if (!record.status.ok()) {
    line["detail"] = record.status.error_message();
  } else if (!record.detail.empty()) {
    line["detail"] = record.detail;
  }
  WriteLine(line);
}

void LogEvent(std::string_view event, std::string_view detail) {
  // Keys one by one: an initializer list can reorder them (ts, event, detail
  // is the order tests and readers rely on).
  nlohmann::ordered_json line = nlohmann::ordered_json::object();
  line["ts"] = Timestamp();
  line["event"] = std::string(event);
  line["detail"] = std::string(detail);
  WriteLine(line);
}

void RouteProtobufLogs() {
  google::protobuf::SetLogHandler([](google::protobuf::LogLevel level, const char* filename,
                                     int line, const std::string& message) {
    static constexpr const char* kLevels[] = {"INFO", "WARNING", "ERROR", "FATAL"};
    const char* name = level >= 0 && level < 4 ? kLevels[level] : "LOG";
    LogEvent("protobuf", absl::StrFormat("%s %s:%d: %s", name, filename, line, message));
  });
}

}  // namespace riskplan::server
