// How riskplan-web reaches riskplan-server: every option of the gRPC link in
// one struct, so that the link's security options (TLS, a bearer token) join
// the address here and nowhere else, and one function that makes the channel
// through the client library's channel creation (client::MakeChannel), never
// a channel set up of its own.
#ifndef RISKPLAN_WEB_SERVER_LINK_H_
#define RISKPLAN_WEB_SERVER_LINK_H_

#include <memory>
#include <string>

#include "grpcpp/grpcpp.h"

namespace riskplan::web {

struct ServerLinkOptions {
  // "host:port" of riskplan-server (or a name resolving to several replicas:
  // the client library balances round-robin over them).
  std::string address = "127.0.0.1:50051";
};

// The channel to the server, created lazily connected: an unreachable server
// shows up as UNAVAILABLE on the first call, which the page shows as it is.
std::shared_ptr<grpc::Channel> MakeServerChannel(const ServerLinkOptions& options);

}  // namespace riskplan::web

#endif  // RISKPLAN_WEB_SERVER_LINK_H_
