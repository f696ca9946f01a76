// gRPC's own log lines, turned into the server's JSON events, and its TLS
// handshake failures reported with the peer they most likely came from.
//
// Why: when the server refuses a client's certificate (missing, from another
// CA, revoked), gRPC 1.51 sends no TLS alert, so the client sees only a
// closed connection; the reason exists only in a line gRPC logs on the
// server ("Certificate verify failed with code 23", "Handshake failed with
// fatal error ... peer did not return a certificate"), and that line names
// no peer. gRPC runs the handshake on its own threads, after the server's
// acceptor has handed the connection over, so the peer is inferred: the
// event names the connection the acceptor handed over last before the
// failure ("peer"), and how many were handed over in the second before it
// ("accepted_last_second"; 1 means the attribution is certain).
//
// Events:
//   {"event":"tls_handshake_failed","detail":"reason=... peer=... accepted_last_second=N"}
//   {"event":"grpc_log","detail":"E ssl_transport_security.cc:1501 ..."}  (every other line)
#ifndef RISKPLAN_SERVER_OBSERVABILITY_GRPC_LOG_H_
#define RISKPLAN_SERVER_OBSERVABILITY_GRPC_LOG_H_

#include <string>

#include "absl/time/time.h"

namespace riskplan::server {

// What the acceptor knows of the connections it handed to gRPC.
struct RecentPeers {
  std::string last_peer;        // "ipv4:127.0.0.1:51234", or "" if none yet
  int accepted_last_second = 0;
};

// Called for every accepted connection by ConnectionAcceptor. Thread-safe.
void NoteAcceptedPeer(const std::string& peer);
RecentPeers RecentAcceptedPeers(absl::Time now);

// Routes gRPC's log lines to LogEvent (server/observability/rpc_log.h). Call once, before
// the gRPC server starts.
void InstallGrpcLogHook();

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_OBSERVABILITY_GRPC_LOG_H_
