// TLS for the shim link (OpenSSL): riskplan-fpga-shim's listener and the
// server's board client, on the blocking-with-deadlines sockets of
// net/net.h. TLS 1.2 at least; mutual TLS when a CA for the peer is given.
//
// Why OpenSSL rather than a pre-shared key: the boards run Linux (the
// DE10-Nano's ARM cores run Debian), where OpenSSL is at hand, and TLS gives
// the link what a PSK scheme would have to rebuild (encryption, replay
// protection, rotation, revocation). docs/security.md and docs/benchmarks.md
// measure what it costs.
//
// Rotation: a listener's context re-reads its files when they change
// (looked at most once a second, on accept), so a certificate rotated by a
// directory swap is served to new connections while open ones keep their
// session. A change that does not load (a half-done swap, a key that does not
// match) is refused and the previous context stays; the next look retries.
//
// A process that builds a context ignores SIGPIPE from then on (OpenSSL
// writes with write(2); see tls_context.cc).
//
// Thread-safe.
#ifndef RISKPLAN_NET_TLS_CONTEXT_H_
#define RISKPLAN_NET_TLS_CONTEXT_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "net/net.h"

typedef struct ssl_ctx_st SSL_CTX;

namespace riskplan::net {

// One end's files. `flag_prefix` is prepended to every flag name in
// messages ("fpga_" gives "--fpga_tls_cert=..."). Every member has an
// initializer, so a designated initializer may name only the files it sets.
struct TlsFiles {
  std::string cert{};  // own certificate chain (PEM); listener: required
  std::string key{};   // its private key (PEM)
  std::string ca{};    // CA that must have signed the peer's certificate; listener: the
                       // client certificate is then required (mutual TLS)
  std::string crl{};   // optional revocation list (PEM) checked on the peer's chain
  std::string flag_prefix{};

  bool enabled() const { return !cert.empty() || !key.empty() || !ca.empty(); }
};

class TlsContext {
 public:
  // Checks the files (net/tls_files.h: missing, unreadable, mismatched or
  // expired ones refused, naming the flag and file) and builds the context.
  static absl::StatusOr<std::shared_ptr<TlsContext>> ForListener(const TlsFiles& files);
  static absl::StatusOr<std::shared_ptr<TlsContext>> ForClient(const TlsFiles& files);
  ~TlsContext();

  // The server side of the handshake on an accepted socket, until
  // `deadline`. On success `socket` carries TLS (SendAll, RecvAll). Errors
  // say why ("peer did not return a certificate", "certificate revoked").
  absl::Status Accept(Socket* socket, absl::Time deadline);
  // The client side: the peer's certificate must be for `server_name` (a DNS
  // name or an IP address) and signed by the CA.
  absl::Status Connect(Socket* socket, const std::string& server_name, absl::Time deadline);

  // A log line for every reload or refused reload since the last call
  // (the shim prints them).
  std::vector<std::string> TakeReloadLog();

 private:
  struct Stamp {
    int64_t mtime_ns = 0, size = 0, inode = 0;
    bool operator==(const Stamp&) const = default;
  };
  TlsContext(TlsFiles files, bool listener) : files_(std::move(files)), listener_(listener) {}
  // The end ForListener and ForClient share once each has checked which files
  // it was given: builds the context (Build) and takes the files' stamps.
  static absl::StatusOr<std::shared_ptr<TlsContext>> Make(const TlsFiles& files, bool listener);
  absl::StatusOr<SSL_CTX*> Build() const;
  std::vector<Stamp> Stamps() const;
  // The context for a new connection, reloaded first if the files changed.
  SSL_CTX* Current();

  const TlsFiles files_;
  const bool listener_;
  absl::Mutex mu_;
  SSL_CTX* ctx_ ABSL_GUARDED_BY(mu_) = nullptr;  // one reference held
  std::vector<Stamp> stamps_ ABSL_GUARDED_BY(mu_);
  absl::Time last_check_ ABSL_GUARDED_BY(mu_);
  std::vector<std::string> reload_log_ ABSL_GUARDED_BY(mu_);
};

}  // namespace riskplan::net

#endif  // RISKPLAN_NET_TLS_CONTEXT_H_
