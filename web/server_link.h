// How riskplan-web reaches riskplan-server: every option of the gRPC link in
// one struct, so that the link's security options (TLS, a bearer token) join
// the address here and nowhere else, and one function that makes the channel
// through the client library's channel creation (client::MakeChannel), never
// a channel set up of its own.
#ifndef RISKPLAN_WEB_SERVER_LINK_H_
#define RISKPLAN_WEB_SERVER_LINK_H_

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "client/client.h"
#include "grpcpp/grpcpp.h"

namespace riskplan::web {

struct ServerLinkOptions {
  // "host:port" of riskplan-server (or a name resolving to several replicas:
  // the client library balances round-robin over them).
  std::string address = "127.0.0.1:50051";
  // TLS, mutual TLS and the bearer token, as `riskplan` takes them (the
  // gateway's --tls_ca, --tls_cert, --tls_key, --tls_server_name and
  // --token_file; docs/security.md). Empty: plaintext without a token.
  client::ConnectionOptions connection;
};

// The channel to the server, created lazily connected: an unreachable server
// or a refused handshake shows up as UNAVAILABLE on the first call, which the
// page shows as it is. An error (naming the flag and file) only when a
// certificate, key or token file cannot be read.
absl::StatusOr<std::shared_ptr<grpc::Channel>> MakeServerChannel(const ServerLinkOptions& options);

}  // namespace riskplan::web

#endif  // RISKPLAN_WEB_SERVER_LINK_H_
