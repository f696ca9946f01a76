#include "web/server_link.h"

#include "client/client.h"

namespace riskplan::web {

std::shared_ptr<grpc::Channel> MakeServerChannel(const ServerLinkOptions& options) {
  return client::MakeChannel(options.address);
}

}  // namespace riskplan::web
