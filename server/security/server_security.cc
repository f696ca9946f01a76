#include "server/security/server_security.h"

#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "grpcpp/security/tls_certificate_provider.h"
#include "grpcpp/security/tls_credentials_options.h"
#include "net/net.h"
#include "net/tls_files.h"

namespace riskplan::server {

absl::StatusOr<ServerSecurity> MakeServerSecurity(const ServerSecurityOptions& o,
                                                  const std::string& listen_host) {
  ServerSecurity security;
  std::shared_ptr<TokenStore> tokens;
  if (!o.token_file.empty()) {
    absl::StatusOr<std::shared_ptr<TokenStore>> loaded = TokenStore::Load(o.token_file);
    if (!loaded.ok()) return loaded.status();
    tokens = *std::move(loaded);
  }
  security.authorizer = std::make_shared<Authorizer>(tokens);
  const std::string token_summary =
      tokens == nullptr ? "tokens=off" : absl::StrFormat("tokens=%d", tokens->size());

  security.tls = !o.tls_cert.empty() || !o.tls_key.empty();
  if (!security.tls) {
    if (!o.tls_client_ca.empty() || !o.tls_crl_dir.empty()) {
      return absl::InvalidArgumentError(
          "--tls_client_ca and --tls_crl_dir need TLS: give --tls_cert and --tls_key too");
    }
    if (!o.allow_plaintext && !net::IsLoopbackHost(listen_host)) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "--listen=%s:... is not a loopback address and no --tls_cert/--tls_key were given: "
          "plaintext there needs --allow_plaintext (docs/security.md)",
          listen_host));
    }
    security.credentials = grpc::InsecureServerCredentials();
    security.summary = absl::StrCat("tls=off ", token_summary);
    return security;
  }
  if (o.tls_cert.empty() || o.tls_key.empty()) {
    return absl::InvalidArgumentError("--tls_cert and --tls_key go together");
  }
  if (o.tls_reload_s < 1) return absl::InvalidArgumentError("--tls_reload_s must be >= 1");
  if (absl::Status s =
          net::CheckCertificateAndKey({"tls_cert", o.tls_cert}, {"tls_key", o.tls_key});
      !s.ok()) {
    return s;
  }
  if (!o.tls_client_ca.empty()) {
    if (absl::Status s = net::CheckCaBundle({"tls_client_ca", o.tls_client_ca}); !s.ok()) {
      return s;
    }
  }
  if (!o.tls_crl_dir.empty()) {
    if (o.tls_client_ca.empty()) {
      return absl::InvalidArgumentError(
          "--tls_crl_dir revokes client certificates: it needs --tls_client_ca");
    }
    if (absl::Status s = net::CheckCrl({"tls_crl_dir", o.tls_crl_dir}); !s.ok()) return s;
  }
  absl::StatusOr<std::unique_ptr<CertificateRotation>> rotation = CertificateRotation::Start(
      {.cert = o.tls_cert, .key = o.tls_key, .client_ca = o.tls_client_ca}, o.tls_reload_s);
  if (!rotation.ok()) return rotation.status();
  security.rotation = *std::move(rotation);
  auto provider = std::make_shared<grpc::experimental::FileWatcherCertificateProvider>(
      security.rotation->key_path(), security.rotation->cert_path(),
      security.rotation->client_ca_path(), static_cast<unsigned>(o.tls_reload_s));
  grpc::experimental::TlsServerCredentialsOptions options(provider);
  options.watch_identity_key_cert_pairs();
  if (!o.tls_client_ca.empty()) {
    options.watch_root_certs();
    options.set_cert_request_type(GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY);
  } else {
    options.set_cert_request_type(GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE);
  }
  if (!o.tls_crl_dir.empty()) options.set_crl_directory(o.tls_crl_dir);
  security.credentials = grpc::experimental::TlsServerCredentials(options);
  if (tokens != nullptr) {
    // Only on TLS credentials: on plaintext ones gRPC 1.51 aborts.
    security.credentials->SetAuthMetadataProcessor(
        std::make_shared<TokenAuthProcessor>(security.authorizer));
  }
  security.summary =
      absl::StrFormat("tls=%s crl=%s reload_s=%d %s",
                      o.tls_client_ca.empty() ? "server" : "mutual",
                      o.tls_crl_dir.empty() ? "off" : "on", o.tls_reload_s, token_summary);
  return security;
}

}  // namespace riskplan::server
