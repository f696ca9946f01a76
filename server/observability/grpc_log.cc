#include "server/observability/grpc_log.h"

#include <cstring>
#include <deque>

#include "absl/base/thread_annotations.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_format.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/clock.h"
#include "grpc/support/log.h"
#include "openssl/x509.h"
#include "server/observability/rpc_log.h"

namespace riskplan::server {
namespace {

struct AcceptLog {
  absl::Mutex mu;
  // The times and peers of the connections of the last second, newest last.
  std::deque<std::pair<absl::Time, std::string>> recent ABSL_GUARDED_BY(mu);
  std::string last ABSL_GUARDED_BY(mu);
};

AcceptLog& Accepts() {
  static auto* log = new AcceptLog;  // never destroyed: gRPC may log at exit
  return *log;
}

// The certificate check's reason, logged by gRPC just before its
// "Handshake failed" line on the same thread.
thread_local std::string pending_verify_reason;

constexpr absl::string_view kVerifyFailed = "Certificate verify failed with code ";

void OnGrpcLog(gpr_log_func_args* args) {
  const absl::string_view message = args->message != nullptr ? args->message : "";
  if (absl::StartsWith(message, kVerifyFailed)) {
    int code = 0;
    if (absl::SimpleAtoi(message.substr(kVerifyFailed.size()), &code)) {
      pending_verify_reason = absl::StrFormat("client certificate: %s (X509 code %d)",
                                              X509_verify_cert_error_string(code), code);
      return;
    }
  }
  if (absl::StrContains(message, "Handshake failed")) {
    const RecentPeers peers = RecentAcceptedPeers(absl::Now());
    std::string reason = pending_verify_reason.empty() ? std::string(message) : pending_verify_reason;
    pending_verify_reason.clear();
    LogEvent("tls_handshake_failed",
             absl::StrFormat("reason=\"%s\" peer=%s accepted_last_second=%d", reason,
                             peers.last_peer.empty() ? "unknown" : peers.last_peer,
                             peers.accepted_last_second));
    return;
  }
  const char* base = args->file != nullptr ? args->file : "";
  if (const char* slash = strrchr(base, '/')) base = slash + 1;
  LogEvent("grpc_log", absl::StrFormat("%s %s:%d %s", gpr_log_severity_string(args->severity),
                                       base, args->line, message));
}

}  // namespace

void NoteAcceptedPeer(const std::string& peer) {
  AcceptLog& log = Accepts();
  const absl::Time now = absl::Now();
  absl::MutexLock lock(&log.mu);
  log.recent.emplace_back(now, peer);
  while (!log.recent.empty() && now - log.recent.front().first > absl::Seconds(1)) {
    log.recent.pop_front();
  }
  log.last = peer;
}

RecentPeers RecentAcceptedPeers(absl::Time now) {
  AcceptLog& log = Accepts();
  absl::MutexLock lock(&log.mu);
  RecentPeers peers;
  peers.last_peer = log.last;
  for (const auto& [when, peer] : log.recent) {
    if (now - when <= absl::Seconds(1)) ++peers.accepted_last_second;
  }
  return peers;
}

void InstallGrpcLogHook() { gpr_set_log_function(OnGrpcLog); }

}  // namespace riskplan::server
