#include "web/server_link.h"

#include "client/client.h"

namespace riskplan::web {

absl::StatusOr<std::shared_ptr<grpc::Channel>> MakeServerChannel(const ServerLinkOptions& options) {
  return client::MakeChannel(options.address, options.connection);
}

}  // namespace riskplan::web
