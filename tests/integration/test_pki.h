// A throw-away PKI for the TLS tests: tests/integration/test_pki.sh (the
// openssl CLI) run into a fresh temporary directory, so that no key material
// is committed. Needs RISKPLAN_SOURCE_DIR (every test executable has it).
#ifndef RISKPLAN_TESTS_INTEGRATION_TEST_PKI_H_
#define RISKPLAN_TESTS_INTEGRATION_TEST_PKI_H_

#include <stdlib.h>

#include <filesystem>
#include <memory>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "tests/child_process.h"

namespace riskplan::testing {

class TestPki {
 public:
  // Two CAs, "a" and "b", in a new temporary directory (removed with the
  // object).
  static absl::StatusOr<std::unique_ptr<TestPki>> Create() {
    char dir_template[] = "/tmp/riskplan-pki-XXXXXX";
    if (mkdtemp(dir_template) == nullptr) return absl::InternalError("mkdtemp failed");
    std::unique_ptr<TestPki> pki(new TestPki(dir_template));
    if (absl::Status s = pki->Run(absl::StrCat("init ", pki->dir_)); !s.ok()) return s;
    return pki;
  }
  ~TestPki() {
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }

  // NAME.pem and NAME.key: CN `cn`, subjectAltName `san` ("" for none), signed
  // by CA `ca`, for a server or a client, valid from `not_before` to
  // `not_after`.
  absl::Status Issue(const std::string& name, const std::string& ca, const std::string& cn,
                     const std::string& san, bool server, absl::Time not_before,
                     absl::Time not_after) {
    return Run(absl::StrCat("issue ", dir_, " ", name, " ", ca, " '", cn, "' '", san, "' ",
                            server ? "server" : "client", " ", Asn1(not_before), " ",
                            Asn1(not_after)));
  }
  // Valid from an hour ago for a day.
  absl::Status Issue(const std::string& name, const std::string& ca, const std::string& cn,
                     const std::string& san, bool server) {
    return Issue(name, ca, cn, san, server, absl::Now() - absl::Hours(1),
                 absl::Now() + absl::Hours(24));
  }
  // Revokes NAME.pem; CA's CRL goes into crl-CA/ under its hash name.
  absl::Status Revoke(const std::string& name, const std::string& ca) {
    return Run(absl::StrCat("revoke ", dir_, " ", name, " ", ca));
  }
  // NAME-other.key, a key that matches no certificate.
  absl::Status Mismatch(const std::string& name) {
    return Run(absl::StrCat("mismatch ", dir_, " ", name));
  }

  // DIR/file.
  std::string Path(const std::string& file) const { return absl::StrCat(dir_, "/", file); }
  const std::string& dir() const { return dir_; }

 private:
  explicit TestPki(std::string dir) : dir_(std::move(dir)) {}
  static std::string Asn1(absl::Time t) {
    return absl::FormatTime("%Y%m%d%H%M%SZ", t, absl::UTCTimeZone());
  }
  absl::Status Run(const std::string& args) {
    const CommandResult r = RunCommand(
        absl::StrCat("bash ", RISKPLAN_SOURCE_DIR, "/tests/integration/test_pki.sh ", args, " 2>&1"),
        absl::Minutes(2));
    if (r.exit_code != 0) {
      return absl::InternalError(absl::StrCat("test_pki.sh ", args, " failed: ", r.output));
    }
    return absl::OkStatus();
  }

  const std::string dir_;
};

}  // namespace riskplan::testing

#endif  // RISKPLAN_TESTS_INTEGRATION_TEST_PKI_H_
