// Start-up checks of TLS files with OpenSSL, shared by riskplan-server (its
// gRPC port and its board client) and riskplan-fpga-shim.
//
// Why a program checks them itself: gRPC 1.51, given a key that does not
// match its certificate, a broken key or an expired certificate, still
// starts, only logs, and then fails every handshake. A program that checks
// first refuses to start instead, with a message naming the file (and the
// flag that gave it).
//
// Thread-safe (no state).
#ifndef RISKPLAN_NET_TLS_FILES_H_
#define RISKPLAN_NET_TLS_FILES_H_

#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/time/time.h"

namespace riskplan::net {

// A file given by a flag: `flag` is the flag's name without dashes, used in
// every message ("--tls_key=/etc/riskplan/tls.key: ...").
struct FlagFile {
  std::string flag;
  std::string path;
};

// The whole file, or an error naming it (missing, unreadable, larger than
// 1 MiB).
absl::StatusOr<std::string> ReadFlagFile(const FlagFile& file);

// A certificate chain (PEM) and its private key: both readable and parsed,
// the key the certificate's (X509_check_private_key), the leaf certificate
// valid at `now` (not expired, not yet valid). Each error names the file at
// fault.
absl::Status CheckCertificateAndKey(const FlagFile& cert, const FlagFile& key,
                                    absl::Time now = absl::Now());

// A CA bundle (PEM): readable, at least one certificate, none expired at
// `now`.
absl::Status CheckCaBundle(const FlagFile& ca, absl::Time now = absl::Now());

// A certificate revocation list (PEM or a directory of them): readable and
// parsed. A directory must hold at least one file that parses as a CRL.
absl::Status CheckCrl(const FlagFile& crl);

// The subject of the leaf certificate of a PEM chain, "CN=...,O=..." (for
// logs). Empty if it does not parse.
std::string CertificateSubject(const std::string& pem);

// The names the leaf certificate of a PEM chain is for, as a client checks
// them: its subjectAltName DNS names ("riskplan.test") and IP addresses
// ("127.0.0.1"), or its subject's CN when it has no subjectAltName. Empty if
// it does not parse.
std::vector<std::string> CertificateNames(const std::string& pem);

// OpenSSL's queued errors of this thread as one line, "; " between them, and
// the queue emptied. `if_none` when there was none.
std::string OpenSslErrors(const char* if_none = "");

}  // namespace riskplan::net

#endif  // RISKPLAN_NET_TLS_FILES_H_
