#include "net/tls_context.h"

#include <arpa/inet.h>
#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/ssl.h>
#include <openssl/x509v3.h>
#include <sys/stat.h>

#include <csignal>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/time/clock.h"
#include "net/tls_files.h"

namespace riskplan::net {
namespace {

constexpr absl::Duration kReloadCheckEvery = absl::Seconds(1);

// OpenSSL writes to its socket with write(2), not send(MSG_NOSIGNAL) as
// net/net.cc does: a peer that has gone would kill the process with
// SIGPIPE. A process that speaks TLS on the shim link ignores the signal, so
// that a broken connection is the EPIPE error it should be.
void IgnoreSigpipe() {
  static const bool done = [] {
    std::signal(SIGPIPE, SIG_IGN);
    return true;
  }();
  (void)done;
}

FlagFile Flag(const TlsFiles& f, const char* name, const std::string& path) {
  return {absl::StrCat(f.flag_prefix, name), path};
}

// Waits for the socket as OpenSSL asks (SSL_ERROR_WANT_READ/WRITE).
absl::Status WaitAsAsked(const Socket& socket, int ssl_error, absl::Time deadline,
                         const char* what) {
  return WaitReady(socket, ssl_error == SSL_ERROR_WANT_WRITE, deadline, what);
}

}  // namespace

absl::StatusOr<std::shared_ptr<TlsContext>> TlsContext::ForListener(const TlsFiles& files) {
  if (files.cert.empty() || files.key.empty()) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "--%stls_cert and --%stls_key are both needed for TLS", files.flag_prefix,
        files.flag_prefix));
  }
  return Make(files, /*listener=*/true);
}

absl::StatusOr<std::shared_ptr<TlsContext>> TlsContext::ForClient(const TlsFiles& files) {
  if (files.cert.empty() != files.key.empty()) {
    return absl::InvalidArgumentError(absl::StrFormat("--%stls_cert and --%stls_key go together",
                                                      files.flag_prefix, files.flag_prefix));
  }
  return Make(files, /*listener=*/false);
}

absl::StatusOr<std::shared_ptr<TlsContext>> TlsContext::Make(const TlsFiles& files, bool listener) {
  std::shared_ptr<TlsContext> context(new TlsContext(files, listener));
  absl::StatusOr<SSL_CTX*> ctx = context->Build();
  if (!ctx.ok()) return ctx.status();
  absl::MutexLock lock(&context->mu_);
  context->ctx_ = *ctx;
  context->stamps_ = context->Stamps();
  context->last_check_ = absl::Now();
  return context;
}

TlsContext::~TlsContext() {
  absl::MutexLock lock(&mu_);
  SSL_CTX_free(ctx_);
}

std::vector<TlsContext::Stamp> TlsContext::Stamps() const {
  std::vector<Stamp> stamps;
  for (const std::string* path : {&files_.cert, &files_.key, &files_.ca, &files_.crl}) {
    struct stat st {};
    if (path->empty() || stat(path->c_str(), &st) != 0) {
      stamps.push_back({});
      continue;
    }
    stamps.push_back({int64_t{st.st_mtim.tv_sec} * 1000000000 + st.st_mtim.tv_nsec, st.st_size,
                      static_cast<int64_t>(st.st_ino)});
  }
  return stamps;
}

absl::StatusOr<SSL_CTX*> TlsContext::Build() const {
  IgnoreSigpipe();
  const TlsFiles& f = files_;
  if (!f.cert.empty()) {
    if (absl::Status s = CheckCertificateAndKey(Flag(f, "tls_cert", f.cert),
                                                Flag(f, "tls_key", f.key));
        !s.ok()) {
      return s;
    }
  }
  if (!f.ca.empty()) {
    if (absl::Status s = CheckCaBundle(Flag(f, listener_ ? "tls_client_ca" : "tls_ca", f.ca));
        !s.ok()) {
      return s;
    }
  }
  if (!f.crl.empty()) {
    if (absl::Status s = CheckCrl(Flag(f, "tls_crl", f.crl)); !s.ok()) return s;
  }
  ERR_clear_error();
  SSL_CTX* ctx = SSL_CTX_new(listener_ ? TLS_server_method() : TLS_client_method());
  if (ctx == nullptr) return absl::InternalError(absl::StrCat("SSL_CTX_new: ", OpenSslErrors()));
  auto fail = [ctx](const std::string& what) {
    SSL_CTX_free(ctx);
    return absl::InvalidArgumentError(absl::StrCat(what, ": ", OpenSslErrors()));
  };
  SSL_CTX_set_min_proto_version(ctx, TLS1_2_VERSION);
  SSL_CTX_set_mode(ctx, SSL_MODE_ACCEPT_MOVING_WRITE_BUFFER);
  if (!f.cert.empty()) {
    if (SSL_CTX_use_certificate_chain_file(ctx, f.cert.c_str()) != 1) {
      return fail(absl::StrFormat("--%stls_cert=%s", f.flag_prefix, f.cert));
    }
    if (SSL_CTX_use_PrivateKey_file(ctx, f.key.c_str(), SSL_FILETYPE_PEM) != 1 ||
        SSL_CTX_check_private_key(ctx) != 1) {
      // Read a moment apart: a swap between the two reads gives a mismatch.
      return fail(absl::StrFormat("--%stls_key=%s", f.flag_prefix, f.key));
    }
  }
  if (!f.ca.empty()) {
    if (SSL_CTX_load_verify_locations(ctx, f.ca.c_str(), nullptr) != 1) {
      return fail(absl::StrFormat("--%s%s=%s", f.flag_prefix,
                                  listener_ ? "tls_client_ca" : "tls_ca", f.ca));
    }
    if (listener_) SSL_CTX_set_client_CA_list(ctx, SSL_load_client_CA_file(f.ca.c_str()));
  } else if (!listener_) {
    SSL_CTX_set_default_verify_paths(ctx);
  }
  if (!f.crl.empty()) {
    X509_STORE* store = SSL_CTX_get_cert_store(ctx);
    if (X509_STORE_load_file(store, f.crl.c_str()) != 1) {
      return fail(absl::StrFormat("--%stls_crl=%s", f.flag_prefix, f.crl));
    }
    X509_STORE_set_flags(store, X509_V_FLAG_CRL_CHECK);
  }
  // A listener with a CA requires and checks the client's certificate; a
  // client always checks the listener's.
  if (!listener_ || !f.ca.empty()) {
    SSL_CTX_set_verify(ctx, SSL_VERIFY_PEER | (listener_ ? SSL_VERIFY_FAIL_IF_NO_PEER_CERT : 0),
                       nullptr);
  }
  return ctx;
}

SSL_CTX* TlsContext::Current() {
  absl::MutexLock lock(&mu_);
  const absl::Time now = absl::Now();
  if (now - last_check_ >= kReloadCheckEvery) {
    last_check_ = now;
    std::vector<Stamp> stamps = Stamps();
    if (stamps != stamps_) {
      absl::StatusOr<SSL_CTX*> fresh = Build();
      if (fresh.ok()) {
        SSL_CTX_free(ctx_);
        ctx_ = *fresh;
        stamps_ = std::move(stamps);
        reload_log_.push_back(absl::StrCat("TLS files reloaded: ", files_.cert));
      } else {
        // stamps_ unchanged: the next look tries again.
        reload_log_.push_back(absl::StrCat("TLS files changed but do not load (kept the previous "
                                           "ones): ",
                                           fresh.status().message()));
      }
    }
  }
  SSL_CTX_up_ref(ctx_);
  return ctx_;
}

std::vector<std::string> TlsContext::TakeReloadLog() {
  absl::MutexLock lock(&mu_);
  return std::exchange(reload_log_, {});
}

namespace {

// Runs SSL_do_handshake to its end; `ssl` is owned by the caller.
absl::Status Handshake(Socket* socket, SSL* ssl, absl::Time deadline, const char* side) {
  while (true) {
    ERR_clear_error();
    const int rc = SSL_do_handshake(ssl);
    if (rc == 1) return absl::OkStatus();
    const int e = SSL_get_error(ssl, rc);
    if (e == SSL_ERROR_WANT_READ || e == SSL_ERROR_WANT_WRITE) {
      if (absl::Status s = WaitAsAsked(*socket, e, deadline, "TLS handshake"); !s.ok()) return s;
      continue;
    }
    std::string reason = OpenSslErrors();
    const long verify = SSL_get_verify_result(ssl);
    if (verify != X509_V_OK) {
      reason = absl::StrCat(X509_verify_cert_error_string(verify), " (X509 code ", verify, "); ",
                            reason);
    }
    if (reason.empty()) reason = "the peer closed the connection";
    return absl::UnavailableError(absl::StrCat("TLS handshake (", side, ") failed: ", reason));
  }
}

}  // namespace

absl::Status TlsContext::Accept(Socket* socket, absl::Time deadline) {
  SSL_CTX* ctx = Current();
  SSL* ssl = SSL_new(ctx);
  SSL_CTX_free(ctx);  // the SSL holds its own reference
  if (ssl == nullptr) return absl::InternalError(absl::StrCat("SSL_new: ", OpenSslErrors()));
  SSL_set_fd(ssl, socket->fd());
  SSL_set_accept_state(ssl);
  socket->AttachTls(ssl);  // freed with the socket
  return Handshake(socket, ssl, deadline, "this listener");
}

absl::Status TlsContext::Connect(Socket* socket, const std::string& server_name,
                                 absl::Time deadline) {
  SSL_CTX* ctx = Current();
  SSL* ssl = SSL_new(ctx);
  SSL_CTX_free(ctx);
  if (ssl == nullptr) return absl::InternalError(absl::StrCat("SSL_new: ", OpenSslErrors()));
  socket->AttachTls(ssl);
  SSL_set_fd(ssl, socket->fd());
  SSL_set_connect_state(ssl);
  in6_addr ip{};
  const bool is_ip = inet_pton(AF_INET, server_name.c_str(), &ip) == 1 ||
                     inet_pton(AF_INET6, server_name.c_str(), &ip) == 1;
  if (is_ip) {
    X509_VERIFY_PARAM_set1_ip_asc(SSL_get0_param(ssl), server_name.c_str());
  } else {
    SSL_set_tlsext_host_name(ssl, server_name.c_str());
    SSL_set1_host(ssl, server_name.c_str());
  }
  return Handshake(socket, ssl, deadline, "this client");
}

}  // namespace riskplan::net
