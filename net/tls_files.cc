#include "net/tls_files.h"

#include <dirent.h>
#include <openssl/bio.h>
#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/x509.h>
#include <openssl/x509v3.h>
#include <arpa/inet.h>
#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <memory>
#include <sstream>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace riskplan::net {
namespace {

constexpr int64_t kMaxFileBytes = 1 << 20;

struct BioFree {
  void operator()(BIO* b) const { BIO_free(b); }
};
struct X509Free {
  void operator()(X509* x) const { X509_free(x); }
};
struct PkeyFree {
  void operator()(EVP_PKEY* k) const { EVP_PKEY_free(k); }
};
struct CrlFree {
  void operator()(X509_CRL* c) const { X509_CRL_free(c); }
};
using Bio = std::unique_ptr<BIO, BioFree>;
using Cert = std::unique_ptr<X509, X509Free>;

std::string Where(const FlagFile& f) { return absl::StrCat("--", f.flag, "=", f.path); }

Bio MemoryBio(const std::string& bytes) {
  return Bio(BIO_new_mem_buf(bytes.data(), static_cast<int>(bytes.size())));
}

// "2026-12-01 10:00:00 UTC".
std::string AsnTimeText(const ASN1_TIME* t) {
  Bio out(BIO_new(BIO_s_mem()));
  ASN1_TIME_print(out.get(), t);
  char* data = nullptr;
  const long n = BIO_get_mem_data(out.get(), &data);
  return std::string(data, static_cast<size_t>(n));
}

// Not expired and already valid at `now`.
absl::Status CheckValidity(const FlagFile& file, X509* cert, absl::Time now, const char* what) {
  time_t t = absl::ToTimeT(now);
  if (X509_cmp_time(X509_get0_notAfter(cert), &t) <= 0) {
    return absl::FailedPreconditionError(
        absl::StrFormat("%s: the %s expired on %s", Where(file), what,
                        AsnTimeText(X509_get0_notAfter(cert))));
  }
  if (X509_cmp_time(X509_get0_notBefore(cert), &t) > 0) {
    return absl::FailedPreconditionError(
        absl::StrFormat("%s: the %s is not valid before %s", Where(file), what,
                        AsnTimeText(X509_get0_notBefore(cert))));
  }
  return absl::OkStatus();
}

}  // namespace

std::string OpenSslErrors(const char* if_none) {
  std::string text;
  while (unsigned long e = ERR_get_error()) {
    char buffer[256];
    ERR_error_string_n(e, buffer, sizeof(buffer));
    if (!text.empty()) text += "; ";
    text += buffer;
  }
  return text.empty() ? if_none : text;
}

absl::StatusOr<std::string> ReadFlagFile(const FlagFile& file) {
  struct stat st {};
  if (stat(file.path.c_str(), &st) != 0) {
    return absl::NotFoundError(
        absl::StrFormat("%s: cannot read it: %s", Where(file), std::strerror(errno)));
  }
  if (!S_ISREG(st.st_mode)) {
    return absl::InvalidArgumentError(absl::StrFormat("%s: not a regular file", Where(file)));
  }
  if (st.st_size > kMaxFileBytes) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s: %d bytes; at most %d expected", Where(file), st.st_size, kMaxFileBytes));
  }
  std::ifstream in(file.path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  if (!in) {
    return absl::PermissionDeniedError(
        absl::StrFormat("%s: cannot read it: %s", Where(file), std::strerror(errno)));
  }
  return text.str();
}

absl::Status CheckCertificateAndKey(const FlagFile& cert_file, const FlagFile& key_file,
                                    absl::Time now) {
  absl::StatusOr<std::string> key_pem = ReadFlagFile(key_file);
  if (!key_pem.ok()) return key_pem.status();
  absl::StatusOr<std::string> cert_pem = ReadFlagFile(cert_file);
  if (!cert_pem.ok()) return cert_pem.status();
  ERR_clear_error();
  Bio key_bio = MemoryBio(*key_pem);
  std::unique_ptr<EVP_PKEY, PkeyFree> key(
      PEM_read_bio_PrivateKey(key_bio.get(), nullptr, nullptr, nullptr));
  if (key == nullptr) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s: not a PEM private key (or an encrypted one): %s", Where(key_file),
                        OpenSslErrors("no PEM data")));
  }
  Bio cert_bio = MemoryBio(*cert_pem);
  Cert cert(PEM_read_bio_X509(cert_bio.get(), nullptr, nullptr, nullptr));
  if (cert == nullptr) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s: not a PEM certificate: %s", Where(cert_file), OpenSslErrors("no PEM data")));
  }
  if (X509_check_private_key(cert.get(), key.get()) != 1) {
    ERR_clear_error();
    return absl::InvalidArgumentError(
        absl::StrFormat("%s: the certificate does not match the private key %s", Where(cert_file),
                        Where(key_file)));
  }
  return CheckValidity(cert_file, cert.get(), now, "certificate");
}

absl::Status CheckCaBundle(const FlagFile& ca, absl::Time now) {
  absl::StatusOr<std::string> pem = ReadFlagFile(ca);
  if (!pem.ok()) return pem.status();
  ERR_clear_error();
  Bio bio = MemoryBio(*pem);
  int count = 0;
  while (true) {
    Cert cert(PEM_read_bio_X509(bio.get(), nullptr, nullptr, nullptr));
    if (cert == nullptr) break;
    ++count;
    if (absl::Status s = CheckValidity(ca, cert.get(), now, "CA certificate"); !s.ok()) return s;
  }
  ERR_clear_error();  // the end of the bundle reads as an error
  if (count == 0) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s: no PEM certificate in the CA bundle", Where(ca)));
  }
  return absl::OkStatus();
}

absl::Status CheckCrl(const FlagFile& crl) {
  struct stat st {};
  if (stat(crl.path.c_str(), &st) != 0) {
    return absl::NotFoundError(
        absl::StrFormat("%s: cannot read it: %s", Where(crl), std::strerror(errno)));
  }
  std::vector<std::string> files;
  if (S_ISDIR(st.st_mode)) {
    std::unique_ptr<DIR, int (*)(DIR*)> dir(opendir(crl.path.c_str()), closedir);
    if (dir == nullptr) {
      return absl::PermissionDeniedError(
          absl::StrFormat("%s: cannot list the directory: %s", Where(crl), std::strerror(errno)));
    }
    while (dirent* e = readdir(dir.get())) {
      if (e->d_name[0] != '.') files.push_back(absl::StrCat(crl.path, "/", e->d_name));
    }
  } else {
    files.push_back(crl.path);
  }
  int parsed = 0;
  for (const std::string& path : files) {
    absl::StatusOr<std::string> pem = ReadFlagFile({crl.flag, path});
    if (!pem.ok()) {
      if (!S_ISDIR(st.st_mode)) return pem.status();
      continue;  // a directory may hold other files (hash links to them, say)
    }
    Bio bio = MemoryBio(*pem);
    std::unique_ptr<X509_CRL, CrlFree> list(
        PEM_read_bio_X509_CRL(bio.get(), nullptr, nullptr, nullptr));
    ERR_clear_error();
    if (list != nullptr) ++parsed;
  }
  if (parsed == 0) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s: no PEM certificate revocation list in it", Where(crl)));
  }
  return absl::OkStatus();
}

std::string CertificateSubject(const std::string& pem) {
  Bio bio = MemoryBio(pem);
  Cert cert(PEM_read_bio_X509(bio.get(), nullptr, nullptr, nullptr));
  ERR_clear_error();
  if (cert == nullptr) return "";
  Bio out(BIO_new(BIO_s_mem()));
  X509_NAME_print_ex(out.get(), X509_get_subject_name(cert.get()), 0, XN_FLAG_RFC2253);
  char* data = nullptr;
  const long n = BIO_get_mem_data(out.get(), &data);
  return std::string(data, static_cast<size_t>(n));
}

std::vector<std::string> CertificateNames(const std::string& pem) {
  Bio bio = MemoryBio(pem);
  Cert cert(PEM_read_bio_X509(bio.get(), nullptr, nullptr, nullptr));
  ERR_clear_error();
  std::vector<std::string> names;
  if (cert == nullptr) return names;
  GENERAL_NAMES* sans = static_cast<GENERAL_NAMES*>(
      X509_get_ext_d2i(cert.get(), NID_subject_alt_name, nullptr, nullptr));
  if (sans != nullptr) {
    for (int i = 0; i < sk_GENERAL_NAME_num(sans); ++i) {
      const GENERAL_NAME* name = sk_GENERAL_NAME_value(sans, i);
      if (name->type == GEN_DNS) {
        const ASN1_IA5STRING* dns = name->d.dNSName;
        names.emplace_back(reinterpret_cast<const char*>(ASN1_STRING_get0_data(dns)),
                           ASN1_STRING_length(dns));
      } else if (name->type == GEN_IPADD) {
        const ASN1_OCTET_STRING* ip = name->d.iPAddress;
        char text[INET6_ADDRSTRLEN] = {};
        const int family = ASN1_STRING_length(ip) == 4 ? AF_INET : AF_INET6;
        if (inet_ntop(family, ASN1_STRING_get0_data(ip), text, sizeof text) != nullptr) {
          names.emplace_back(text);
        }
      }
    }
    GENERAL_NAMES_free(sans);
    return names;
  }
  X509_NAME* subject = X509_get_subject_name(cert.get());
  const int index = X509_NAME_get_index_by_NID(subject, NID_commonName, -1);
  if (index >= 0) {
    const ASN1_STRING* cn = X509_NAME_ENTRY_get_data(X509_NAME_get_entry(subject, index));
    names.emplace_back(reinterpret_cast<const char*>(ASN1_STRING_get0_data(cn)),
                       ASN1_STRING_length(cn));
  }
  return names;
}

}  // namespace riskplan::net
