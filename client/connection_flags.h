// The flags of every program that is a client of riskplan-server (`riskplan`,
// `riskplan-web`): --tls_ca, --tls_cert, --tls_key, --tls_server_name and
// --token_file, defined once here so that they read and mean the same in
// each (docs/security.md).
#ifndef RISKPLAN_CLIENT_CONNECTION_FLAGS_H_
#define RISKPLAN_CLIENT_CONNECTION_FLAGS_H_

#include "client/client.h"

namespace riskplan::client {

// The ConnectionOptions the flags give. Call after absl::ParseCommandLine.
ConnectionOptions ConnectionOptionsFromFlags();

}  // namespace riskplan::client

#endif  // RISKPLAN_CLIENT_CONNECTION_FLAGS_H_
