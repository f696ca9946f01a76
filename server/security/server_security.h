// The security of riskplan-server's gRPC port: TLS or mutual TLS with
// certificates reloaded from disk, revocation lists, bearer tokens, and the
// rule that plaintext is served only on loopback unless asked for.
//
// Certificates are read by gRPC's FileWatcherCertificateProvider, which
// re-reads the key, the certificate chain and the client CA every
// `reload_s` seconds, from a private copy that CertificateRotation
// (certificate_rotation.h) replaces only with files that pass the start-up
// checks: a bad rotation is refused and the last good pair stays served.
// It reads the key and the chain together, so a rotation
// must replace them together: write the new files into a new directory and
// rename it over the old one, or flip a symlink to it (Kubernetes Secret
// volumes do the latter). Connections made before a rotation keep their
// session; new ones get the new certificate. The files are checked at
// start-up (net/tls_files.h) because gRPC would start with bad ones.
//
// Thread-compatible; built once at start-up.
#ifndef RISKPLAN_SERVER_SECURITY_SERVER_SECURITY_H_
#define RISKPLAN_SERVER_SECURITY_SERVER_SECURITY_H_

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "grpcpp/security/server_credentials.h"
#include "server/security/auth.h"
#include "server/security/certificate_rotation.h"

namespace riskplan::server {

struct ServerSecurityOptions {
  std::string tls_cert;       // PEM chain, leaf first; with tls_key: TLS
  std::string tls_key;        // PEM private key, unencrypted
  std::string tls_client_ca;  // set: mutual TLS, client certificates required, verified by it
  std::string tls_crl_dir;    // set: hashed CRLs (openssl rehash) checked on every handshake
  int tls_reload_s = 10;      // how often the files are read again
  std::string token_file;     // set: bearer tokens required (server/security/auth.h)
  bool allow_plaintext = false;  // plaintext on a non-loopback address
};

struct ServerSecurity {
  std::shared_ptr<grpc::ServerCredentials> credentials;
  // Every Planner handler asks it (never null; without --token_file it
  // allows every call and names callers by certificate only).
  std::shared_ptr<Authorizer> authorizer;
  bool tls = false;
  // With TLS: the checked copies the credentials read (null without TLS).
  std::shared_ptr<CertificateRotation> rotation;
  // "tls=mutual tokens=3 crl=on" for the log.
  std::string summary;
};

// Checks the options and their files and builds the port's credentials.
// `listen_host` is --listen's host. Refuses: a key without a certificate or
// the reverse, a client CA, CRL or reload interval without TLS, any bad file
// (net/tls_files.h), a bad token file, and plaintext on a non-loopback
// host without allow_plaintext. Every message names the flag and the file.
absl::StatusOr<ServerSecurity> MakeServerSecurity(const ServerSecurityOptions& options,
                                                  const std::string& listen_host);

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_SECURITY_SERVER_SECURITY_H_
