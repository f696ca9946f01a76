// ChannelTarget: the gRPC target for a `--server` value. gRPC itself takes
// one address ("host:port", resolved by DNS, every address of the name used)
// or a URI ("dns:///riskplan-server:50051", "ipv4:10.0.0.1:50051,10.0.0.2:50051");
// this adds the static list a ground station is configured with, several
// "host:port" entries separated by commas, one per replica. Its names are
// resolved once, here, into gRPC's ipv4: or ipv6: list, over which the
// channel balances round-robin (client/client.h, MakeChannel).
#ifndef RISKPLAN_CLIENT_CHANNEL_TARGET_H_
#define RISKPLAN_CLIENT_CHANNEL_TARGET_H_

#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace riskplan::client {

// Most entries a static list may hold (replicas of one service).
inline constexpr int kMaxStaticTargets = 64;

// `address` as gRPC takes it: unchanged when it is one address or already a
// URI of a scheme gRPC resolves (dns:, ipv4:, ipv6:, unix:, unix-abstract:);
// for a comma-separated list of "host:port" (IPv6 literals in brackets),
// every entry resolved to its IPv4 addresses (or, for a name with none, its
// IPv6 ones) and joined into one "ipv4:..." or "ipv6:..." target. Errors
// (InvalidArgument) name the entry: empty, no port, a port outside 1..65535,
// a name that does not resolve, more than kMaxStaticTargets entries, or
// entries of both families (gRPC's lists hold one).
absl::StatusOr<std::string> ChannelTarget(absl::string_view address);

}  // namespace riskplan::client

#endif  // RISKPLAN_CLIENT_CHANNEL_TARGET_H_
