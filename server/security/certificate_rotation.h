// The gRPC port's certificate rotation, checked before it is served.
//
// gRPC's FileWatcherCertificateProvider serves whatever the files hold when
// it re-reads them: a rotation to an expired certificate, to one for other
// names, or to a key that does not match would be served as is and lock
// every client out. So the provider never reads the operator's files: it
// reads a private copy (a directory of our own, mode 0700), and this class
// replaces that copy only with files that pass the start-up checks and keep
// a name clients dial. Every `reload_s` seconds it looks at the operator's
// files (--tls_cert, --tls_key, --tls_client_ca); when one changed it checks
// them all:
//   - the certificate and key parse and match, the leaf is valid now
//     (net::CheckCertificateAndKey), the client CA bundle too;
//   - the new leaf is for at least one name the served one is for (a
//     subjectAltName DNS name or IP address, else the CN): clients check the
//     name, so a certificate that drops all of them refuses every client.
//     A rename goes through a certificate that carries both names.
// A rotation that passes is copied in (a new directory, then a symlink
// renamed over the old one: gRPC never reads half of it) and logged as
// `tls_reloaded`; one that fails keeps the last good files, is logged as
// `tls_reload_refused` with the reason and counted
// (`riskplan_tls_reloads_refused_total`); the next change is checked again.
// The FPGA shim's listener does the same (net/tls_context.h).
//
// Thread-safe; one background thread, stopped by the destructor.
#ifndef RISKPLAN_SERVER_SECURITY_CERTIFICATE_ROTATION_H_
#define RISKPLAN_SERVER_SECURITY_CERTIFICATE_ROTATION_H_

#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "absl/synchronization/notification.h"
#include "prometheus/counter.h"
#include "prometheus/registry.h"

namespace riskplan::server {

class CertificateRotation {
 public:
  struct Files {
    std::string cert;       // --tls_cert
    std::string key;        // --tls_key
    std::string client_ca;  // --tls_client_ca, or empty
  };

  // Copies `files` (already checked by the caller) into a new private
  // directory and starts watching them every `reload_s` seconds.
  static absl::StatusOr<std::unique_ptr<CertificateRotation>> Start(const Files& files,
                                                                    int reload_s);
  // Stops the thread and removes the private directory.
  ~CertificateRotation();

  // What the certificate provider reads: the last good copies.
  std::string cert_path() const;
  std::string key_path() const;
  std::string client_ca_path() const;  // empty without a client CA

  // `riskplan_tls_reloads_refused_total` and `riskplan_tls_reloads_total`.
  std::shared_ptr<prometheus::Registry> metrics() const { return registry_; }

  // Looks at the files once (what the thread does every reload_s seconds):
  // true when a changed set was checked and copied in.
  bool CheckNow();

 private:
  struct Stamp {
    int64_t mtime_ns = 0, size = 0, inode = 0;
    bool operator==(const Stamp&) const = default;
  };
  CertificateRotation(Files files, std::string dir, int reload_s);
  std::vector<Stamp> Stamps() const;
  // Checks the files and copies them into a new generation; the reason when
  // they are refused.
  absl::Status Install() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  const Files files_;
  const std::string dir_;  // the private directory
  const int reload_s_;
  std::shared_ptr<prometheus::Registry> registry_;
  prometheus::Counter* refused_ = nullptr;
  prometheus::Counter* reloaded_ = nullptr;
  absl::Mutex mu_;
  std::vector<Stamp> stamps_ ABSL_GUARDED_BY(mu_);
  int generation_ ABSL_GUARDED_BY(mu_) = 0;
  std::vector<std::string> names_ ABSL_GUARDED_BY(mu_);  // of the served leaf
  absl::Notification stop_;
  std::thread thread_;
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_SECURITY_CERTIFICATE_ROTATION_H_
