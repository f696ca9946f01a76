#include "server/security/certificate_rotation.h"

#include <stdlib.h>
#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_replace.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "net/tls_files.h"
#include "server/observability/rpc_log.h"

namespace riskplan::server {
namespace {

namespace fs = std::filesystem;

constexpr char kCert[] = "tls.crt";
constexpr char kKey[] = "tls.key";
constexpr char kCa[] = "ca.pem";

absl::Status WriteWhole(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << bytes;
  out.close();
  if (!out) {
    return absl::InternalError(
        absl::StrFormat("cannot write %s: %s", path, std::strerror(errno)));
  }
  return absl::OkStatus();
}

}  // namespace

CertificateRotation::CertificateRotation(Files files, std::string dir, int reload_s)
    : files_(std::move(files)),
      dir_(std::move(dir)),
      reload_s_(reload_s),
      registry_(std::make_shared<prometheus::Registry>()) {
  refused_ = &prometheus::BuildCounter()
                  .Name("riskplan_tls_reloads_refused_total")
                  .Help("Certificate rotations of the gRPC port refused (expired, not yet "
                        "valid, key not matching, none of the served names, unreadable): the "
                        "last good certificate stays served")
                  .Register(*registry_)
                  .Add({});
  reloaded_ = &prometheus::BuildCounter()
                   .Name("riskplan_tls_reloads_total")
                   .Help("Certificate rotations of the gRPC port checked and served")
                   .Register(*registry_)
                   .Add({});
}

absl::StatusOr<std::unique_ptr<CertificateRotation>> CertificateRotation::Start(
    const Files& files, int reload_s) {
  const char* tmp = getenv("TMPDIR");
  std::string dir_template =
      absl::StrCat(tmp != nullptr && *tmp != '\0' ? tmp : "/tmp", "/riskplan-tls-XXXXXX");
  if (mkdtemp(dir_template.data()) == nullptr) {
    return absl::InternalError(absl::StrFormat(
        "cannot make a private directory for the TLS files (%s): %s", dir_template,
        std::strerror(errno)));
  }
  std::unique_ptr<CertificateRotation> rotation(
      new CertificateRotation(files, dir_template, reload_s));
  {
    absl::MutexLock lock(&rotation->mu_);
    rotation->stamps_ = rotation->Stamps();
    if (absl::Status s = rotation->Install(); !s.ok()) return s;
  }
  rotation->thread_ = std::thread([r = rotation.get()] {
    while (!r->stop_.WaitForNotificationWithTimeout(absl::Seconds(r->reload_s_))) {
      r->CheckNow();
    }
  });
  return rotation;
}

CertificateRotation::~CertificateRotation() {
  stop_.Notify();
  if (thread_.joinable()) thread_.join();
  std::error_code ignored;
  fs::remove_all(dir_, ignored);
}

std::string CertificateRotation::cert_path() const { return absl::StrCat(dir_, "/live/", kCert); }
std::string CertificateRotation::key_path() const { return absl::StrCat(dir_, "/live/", kKey); }
std::string CertificateRotation::client_ca_path() const {
  return files_.client_ca.empty() ? "" : absl::StrCat(dir_, "/live/", kCa);
}

std::vector<CertificateRotation::Stamp> CertificateRotation::Stamps() const {
  std::vector<Stamp> stamps;
  for (const std::string* path : {&files_.cert, &files_.key, &files_.client_ca}) {
    struct stat st {};
    if (path->empty() || stat(path->c_str(), &st) != 0) {
      stamps.push_back(Stamp{});
      continue;
    }
    stamps.push_back(Stamp{.mtime_ns = int64_t{st.st_mtim.tv_sec} * 1000000000 + st.st_mtim.tv_nsec,
                           .size = st.st_size,
                           .inode = static_cast<int64_t>(st.st_ino)});
  }
  return stamps;
}

bool CertificateRotation::CheckNow() {
  absl::MutexLock lock(&mu_);
  const std::vector<Stamp> now = Stamps();
  if (now == stamps_) return false;
  // Taken even when refused: a refused set is not checked again until one of
  // its files changes again.
  stamps_ = now;
  if (absl::Status s = Install(); !s.ok()) {
    refused_->Increment();
    LogEvent("tls_reload_refused",
             absl::StrFormat("refused=%d reason=\"%s\"; the last good certificate stays served",
                             static_cast<int64_t>(refused_->Value()), s.message()));
    return false;
  }
  reloaded_->Increment();
  LogEvent("tls_reloaded", absl::StrFormat("cert=%s names=[%s]", files_.cert,
                                           absl::StrJoin(names_, ",")));
  return true;
}

absl::Status CertificateRotation::Install() {
  const std::string next = absl::StrCat(dir_, "/v", generation_ + 1);
  std::error_code ignored;
  fs::remove_all(next, ignored);
  if (!fs::create_directory(next, ignored)) {
    return absl::InternalError(absl::StrFormat("cannot make %s", next));
  }
  // The bytes are read once and checked as copied, so what is checked is
  // what gRPC will read, even if the operator's files change meanwhile.
  struct Copy {
    const char* flag;
    std::string source, target, bytes;
  };
  std::vector<Copy> copies = {{"tls_cert", files_.cert, absl::StrCat(next, "/", kCert), ""},
                              {"tls_key", files_.key, absl::StrCat(next, "/", kKey), ""}};
  if (!files_.client_ca.empty()) {
    copies.push_back({"tls_client_ca", files_.client_ca, absl::StrCat(next, "/", kCa), ""});
  }
  const auto fail = [&](const absl::Status& s) {
    std::string message(s.message());
    for (const Copy& c : copies) absl::StrReplaceAll({{c.target, c.source}}, &message);
    fs::remove_all(next, ignored);
    return absl::Status(s.code(), message);
  };
  for (Copy& c : copies) {
    absl::StatusOr<std::string> bytes = net::ReadFlagFile({c.flag, c.source});
    if (!bytes.ok()) return fail(bytes.status());
    c.bytes = *std::move(bytes);
    if (absl::Status s = WriteWhole(c.target, c.bytes); !s.ok()) return fail(s);
  }
  if (absl::Status s = net::CheckCertificateAndKey({"tls_cert", copies[0].target},
                                                   {"tls_key", copies[1].target});
      !s.ok()) {
    return fail(s);
  }
  if (copies.size() > 2) {
    if (absl::Status s = net::CheckCaBundle({"tls_client_ca", copies[2].target}); !s.ok()) {
      return fail(s);
    }
  }
  std::vector<std::string> names = net::CertificateNames(copies[0].bytes);
  if (!names_.empty()) {
    const bool keeps_one = std::any_of(names.begin(), names.end(), [&](const std::string& n) {
      return std::find(names_.begin(), names_.end(), n) != names_.end();
    });
    if (!keeps_one) {
      return fail(absl::FailedPreconditionError(absl::StrFormat(
          "--tls_cert=%s: the new certificate is for [%s], none of the names the served one "
          "is for ([%s]): every client checking the name would be refused (rotate through a "
          "certificate for both)",
          copies[0].target, absl::StrJoin(names, ","), absl::StrJoin(names_, ","))));
    }
  }
  // The switch: a new symlink renamed over the old one (rename(2) is atomic).
  const std::string link = absl::StrCat(dir_, "/live");
  const std::string link_next = absl::StrCat(dir_, "/live.next");
  fs::remove(link_next, ignored);
  fs::create_directory_symlink(absl::StrCat("v", generation_ + 1), link_next, ignored);
  if (ignored) return fail(absl::InternalError("cannot link the new TLS files"));
  fs::rename(link_next, link, ignored);
  if (ignored) return fail(absl::InternalError("cannot switch to the new TLS files"));
  // The generation before the one just replaced is no longer read by anyone;
  // the replaced one may still be mid-read by gRPC, so it stays one round.
  fs::remove_all(absl::StrCat(dir_, "/v", generation_ - 1), ignored);
  ++generation_;
  names_ = std::move(names);
  return absl::OkStatus();
}

}  // namespace riskplan::server
