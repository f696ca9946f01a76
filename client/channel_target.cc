#include "client/channel_target.h"

#include <netdb.h>
#include <sys/socket.h>
#include <sys/types.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"

namespace riskplan::client {
namespace {

// The schemes whose targets go to gRPC unchanged, lists included.
constexpr absl::string_view kSchemes[] = {"dns:", "ipv4:", "ipv6:", "unix:", "unix-abstract:"};

struct Resolved {
  int family = AF_UNSPEC;
  std::vector<std::string> addresses;  // numeric, with the port; IPv6 in brackets
};

// The addresses of `host` in `family` with `port`; an empty list when it has
// none in that family, the resolver's message when the name is unknown.
absl::StatusOr<std::vector<std::string>> Lookup(const std::string& host, const std::string& port,
                                                int family) {
  addrinfo hints{};
  hints.ai_family = family;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_NUMERICSERV;
  addrinfo* found = nullptr;
  const int rc = getaddrinfo(host.c_str(), port.c_str(), &hints, &found);
  if (rc == EAI_NONAME || rc == EAI_NODATA || rc == EAI_ADDRFAMILY) return std::vector<std::string>{};
  if (rc != 0) return absl::InvalidArgumentError(gai_strerror(rc));
  std::vector<std::string> out;
  for (const addrinfo* a = found; a != nullptr; a = a->ai_next) {
    char text[NI_MAXHOST];
    if (getnameinfo(a->ai_addr, a->ai_addrlen, text, sizeof text, nullptr, 0, NI_NUMERICHOST) != 0) {
      continue;
    }
    const std::string entry = family == AF_INET6 ? absl::StrFormat("[%s]:%s", text, port)
                                                 : absl::StrFormat("%s:%s", text, port);
    if (std::find(out.begin(), out.end(), entry) == out.end()) out.push_back(entry);
  }
  freeaddrinfo(found);
  return out;
}

absl::StatusOr<Resolved> ResolveEntry(absl::string_view entry) {
  std::string host;
  absl::string_view port;
  if (absl::StartsWith(entry, "[")) {
    const size_t close = entry.find(']');
    if (close == absl::string_view::npos || close + 1 >= entry.size() || entry[close + 1] != ':') {
      return absl::InvalidArgumentError("an IPv6 address is written [ADDRESS]:PORT");
    }
    host = std::string(entry.substr(1, close - 1));
    port = entry.substr(close + 2);
  } else {
    const size_t colon = entry.rfind(':');
    if (colon == absl::string_view::npos || entry.find(':') != colon) {
      return absl::InvalidArgumentError("expected HOST:PORT");
    }
    host = std::string(entry.substr(0, colon));
    port = entry.substr(colon + 1);
  }
  uint32_t port_number = 0;
  if (host.empty() || !absl::SimpleAtoi(port, &port_number) || port_number < 1 ||
      port_number > 65535) {
    return absl::InvalidArgumentError("expected HOST:PORT with a port in 1..65535");
  }
  const std::string port_text = std::to_string(port_number);
  for (int family : {AF_INET, AF_INET6}) {
    absl::StatusOr<std::vector<std::string>> found = Lookup(host, port_text, family);
    if (!found.ok()) return found.status();
    if (!found->empty()) return Resolved{family, *std::move(found)};
  }
  return absl::InvalidArgumentError("the name does not resolve to any address");
}

}  // namespace

absl::StatusOr<std::string> ChannelTarget(absl::string_view address) {
  if (!absl::StrContains(address, ',')) return std::string(address);
  for (absl::string_view scheme : kSchemes) {
    if (absl::StartsWith(address, scheme)) return std::string(address);
  }
  const std::vector<absl::string_view> entries = absl::StrSplit(address, ',');
  if (entries.size() > static_cast<size_t>(kMaxStaticTargets)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s: a list of %d servers; at most %d", address, entries.size(), kMaxStaticTargets));
  }
  int family = AF_UNSPEC;
  std::vector<std::string> all;
  for (size_t i = 0; i < entries.size(); ++i) {
    const absl::string_view entry = absl::StripAsciiWhitespace(entries[i]);
    if (entry.empty()) {
      return absl::InvalidArgumentError(
          absl::StrFormat("%s: entry %d of the list is empty", address, i + 1));
    }
    absl::StatusOr<Resolved> resolved = ResolveEntry(entry);
    if (!resolved.ok()) {
      return absl::InvalidArgumentError(absl::StrFormat("%s: entry %d (\"%s\"): %s", address,
                                                        i + 1, entry,
                                                        resolved.status().message()));
    }
    if (family != AF_UNSPEC && resolved->family != family) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "%s: entry %d (\"%s\") is IPv%d while the ones before it are IPv%d; a list holds one "
          "family",
          address, i + 1, entry, resolved->family == AF_INET ? 4 : 6, family == AF_INET ? 4 : 6));
    }
    family = resolved->family;
    for (std::string& a : resolved->addresses) {
      if (std::find(all.begin(), all.end(), a) == all.end()) all.push_back(std::move(a));
    }
  }
  return absl::StrCat(family == AF_INET ? "ipv4:" : "ipv6:", absl::StrJoin(all, ","));
}

}  // namespace riskplan::client
