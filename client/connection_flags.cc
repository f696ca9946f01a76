#include "client/connection_flags.h"

#include <string>

#include "absl/flags/flag.h"

ABSL_FLAG(std::string, tls_ca, "",
          "TLS: CA bundle (PEM) that signed the server's certificate; any --tls_* flag turns TLS "
          "on (without --tls_ca the system's roots are trusted)");
ABSL_FLAG(std::string, tls_cert, "", "Mutual TLS: this client's certificate chain (PEM)");
ABSL_FLAG(std::string, tls_key, "", "Mutual TLS: the private key of --tls_cert (PEM)");
ABSL_FLAG(std::string, tls_server_name, "",
          "TLS: the name the server's certificate must carry, when it is not --server's host");
ABSL_FLAG(std::string, token_file, "",
          "File holding a bearer token, sent with every call to the server (docs/security.md)");

namespace riskplan::client {

ConnectionOptions ConnectionOptionsFromFlags() {
  ConnectionOptions o;
  o.tls_ca = absl::GetFlag(FLAGS_tls_ca);
  o.tls_cert = absl::GetFlag(FLAGS_tls_cert);
  o.tls_key = absl::GetFlag(FLAGS_tls_key);
  o.tls_server_name = absl::GetFlag(FLAGS_tls_server_name);
  o.token_file = absl::GetFlag(FLAGS_token_file);
  return o;
}

}  // namespace riskplan::client
