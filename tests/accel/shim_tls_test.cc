// The refusal matrix of the FPGA shim link: the shim's own listener
// (ShimServer, as riskplan-fpga-shim runs it) and the server's board client
// (ShimClient) over TLS, with certificates made at test time by the openssl
// CLI (tests/integration/test_pki.sh). Each case checks the status and the
// words of the error on the side that refused.
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/clock.h"
#include "accel/shim/device.h"
#include "accel/shim/shim_server.h"
#include "accel/shim_client.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "net/tls_context.h"
#include "tests/child_process.h"
#include "tests/integration/test_pki.h"

namespace riskplan::accel {
namespace {

using ::testing::HasSubstr;
using testing::TestPki;

// What the shim would print (refused handshakes, reloads).
class EventLog {
 public:
  void Add(const std::string& line) {
    absl::MutexLock lock(&mu_);
    lines_ += line + "\n";
  }
  // Waits until the log contains `text` (the shim's connection thread logs
  // just after the client saw its error); the log.
  std::string WaitFor(const std::string& text) {
    absl::MutexLock lock(&mu_);
    auto has = [&] { return lines_.find(text) != std::string::npos; };
    mu_.AwaitWithTimeout(absl::Condition(&has), absl::Seconds(20));
    return lines_;
  }

 private:
  absl::Mutex mu_;
  std::string lines_ ABSL_GUARDED_BY(mu_);
};

class ShimTlsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    absl::StatusOr<std::unique_ptr<TestPki>> pki = TestPki::Create();
    ASSERT_TRUE(pki.ok()) << pki.status();
    pki_ = pki->release();
    ASSERT_TRUE(pki_->Issue("shim", "a", "board-1", "DNS:board-1.riskplan.test,IP:127.0.0.1", true).ok());
    ASSERT_TRUE(pki_->Issue("server", "a", "riskplan-server", "", false).ok());
    ASSERT_TRUE(pki_->Issue("rogue", "b", "rogue", "", false).ok());
    ASSERT_TRUE(pki_->Issue("revoked", "a", "revoked-server", "", false).ok());
    ASSERT_TRUE(pki_->Revoke("revoked", "a").ok());
    ASSERT_TRUE(pki_->Issue("expired", "a", "board-1", "DNS:board-1.riskplan.test", true,
                            absl::Now() - absl::Hours(48), absl::Now() - absl::Hours(24))
                    .ok());
  }
  static void TearDownTestSuite() {
    delete pki_;
    pki_ = nullptr;
  }
  static std::string P(const std::string& f) { return pki_->Path(f); }

  // A shim listening on 127.0.0.1 with `tls` (null: plaintext).
  std::string StartShim(std::shared_ptr<net::TlsContext> tls) {
    ShimServerOptions options;
    options.tls = std::move(tls);
    options.on_tls_event = [this](const std::string& line) { events_.Add(line); };
    shim_ = std::make_unique<ShimServer>(std::make_unique<ModelDevice>(NumberFormat::Board()),
                                         options);
    absl::StatusOr<std::string> bound = shim_->Start("127.0.0.1:0");
    EXPECT_TRUE(bound.ok()) << bound.status();
    return bound.value_or("");
  }
  static std::shared_ptr<net::TlsContext> ShimTls(const std::string& cert = "shim",
                                                  const std::string& crl = "") {
    absl::StatusOr<std::shared_ptr<net::TlsContext>> tls = net::TlsContext::ForListener(
        {.cert = P(cert + ".pem"), .key = P(cert + ".key"), .ca = P("ca-a.pem"), .crl = crl});
    EXPECT_TRUE(tls.ok()) << tls.status();
    return tls.value_or(nullptr);
  }
  static ShimClientOptions Client(const std::string& cert, const std::string& ca = "ca-a.pem",
                                  const std::string& name = "") {
    net::TlsFiles files{.ca = P(ca)};
    if (!cert.empty()) {
      files.cert = P(cert + ".pem");
      files.key = P(cert + ".key");
    }
    absl::StatusOr<std::shared_ptr<net::TlsContext>> tls = net::TlsContext::ForClient(files);
    EXPECT_TRUE(tls.ok()) << tls.status();
    ShimClientOptions options;
    options.tls = tls.value_or(nullptr);
    options.tls_server_name = name;
    return options;
  }

  static TestPki* pki_;
  EventLog events_;
  std::unique_ptr<ShimServer> shim_;
};
TestPki* ShimTlsTest::pki_ = nullptr;

TEST_F(ShimTlsTest, MutualTlsCarriesTheProtocol) {
  const std::string endpoint = StartShim(ShimTls());
  absl::StatusOr<std::unique_ptr<ShimClient>> client = ShimClient::Connect(endpoint, Client("server"));
  ASSERT_TRUE(client.ok()) << client.status();
  EXPECT_TRUE((*client)->Ping().ok());
  EXPECT_EQ((*client)->hello().lanes, 1u);
}

TEST_F(ShimTlsTest, PlaintextClientToATlsShimIsRefused) {
  const std::string endpoint = StartShim(ShimTls());
  absl::StatusOr<std::unique_ptr<ShimClient>> client = ShimClient::Connect(endpoint, {});
  ASSERT_FALSE(client.ok());
  EXPECT_EQ(client.status().code(), absl::StatusCode::kUnavailable) << client.status();
  EXPECT_THAT(events_.WaitFor("refused"), HasSubstr("TLS handshake (this listener) failed"));
}

TEST_F(ShimTlsTest, TlsClientToAPlaintextShimIsRefused) {
  const std::string endpoint = StartShim(nullptr);
  absl::StatusOr<std::unique_ptr<ShimClient>> client = ShimClient::Connect(endpoint, Client("server"));
  ASSERT_FALSE(client.ok());
  EXPECT_EQ(client.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_THAT(std::string(client.status().message()), HasSubstr("TLS handshake (this client) failed"));
}

TEST_F(ShimTlsTest, ShimCertificateFromAnotherCaIsRefusedByTheServer) {
  const std::string endpoint = StartShim(ShimTls());
  absl::StatusOr<std::unique_ptr<ShimClient>> client =
      ShimClient::Connect(endpoint, Client("server", "ca-b.pem"));
  ASSERT_FALSE(client.ok());
  EXPECT_THAT(std::string(client.status().message()),
              ::testing::AllOf(HasSubstr("TLS handshake (this client) failed"),
                               HasSubstr("certificate verify failed")));
}

TEST_F(ShimTlsTest, WrongShimNameIsRefusedByTheServer) {
  const std::string endpoint = StartShim(ShimTls());
  absl::StatusOr<std::unique_ptr<ShimClient>> wrong =
      ShimClient::Connect(endpoint, Client("server", "ca-a.pem", "board-2.riskplan.test"));
  ASSERT_FALSE(wrong.ok());
  EXPECT_THAT(std::string(wrong.status().message()), HasSubstr("hostname mismatch"));
  absl::StatusOr<std::unique_ptr<ShimClient>> right =
      ShimClient::Connect(endpoint, Client("server", "ca-a.pem", "board-1.riskplan.test"));
  EXPECT_TRUE(right.ok()) << right.status();
}

TEST_F(ShimTlsTest, ServerWithoutACertificateIsRefusedByTheShim) {
  const std::string endpoint = StartShim(ShimTls());
  absl::StatusOr<std::unique_ptr<ShimClient>> client = ShimClient::Connect(endpoint, Client(""));
  ASSERT_FALSE(client.ok());
  EXPECT_THAT(std::string(client.status().message()), HasSubstr("certificate required"));
  EXPECT_THAT(events_.WaitFor("refused"), HasSubstr("peer did not return a certificate"));
}

TEST_F(ShimTlsTest, ServerCertificateFromAnotherCaIsRefusedByTheShim) {
  const std::string endpoint = StartShim(ShimTls());
  absl::StatusOr<std::unique_ptr<ShimClient>> client = ShimClient::Connect(endpoint, Client("rogue"));
  ASSERT_FALSE(client.ok());
  EXPECT_THAT(events_.WaitFor("refused"),
              HasSubstr("refused 127.0.0.1:"));
  EXPECT_THAT(events_.WaitFor("unable to get local issuer"),
              HasSubstr("unable to get local issuer certificate (X509 code 20)"));
}

TEST_F(ShimTlsTest, RevokedServerCertificateIsRefusedByTheShim) {
  const std::string endpoint = StartShim(ShimTls("shim", P("crl-a.pem")));
  absl::StatusOr<std::unique_ptr<ShimClient>> revoked =
      ShimClient::Connect(endpoint, Client("revoked"));
  ASSERT_FALSE(revoked.ok());
  EXPECT_THAT(events_.WaitFor("revoked"), HasSubstr("certificate revoked (X509 code 23)"));
  absl::StatusOr<std::unique_ptr<ShimClient>> good = ShimClient::Connect(endpoint, Client("server"));
  EXPECT_TRUE(good.ok()) << good.status();
}

TEST_F(ShimTlsTest, ExpiredOrMismatchedShimCertificateIsRefusedAtStart) {
  absl::StatusOr<std::shared_ptr<net::TlsContext>> expired = net::TlsContext::ForListener(
      {.cert = P("expired.pem"), .key = P("expired.key"), .ca = P("ca-a.pem")});
  ASSERT_FALSE(expired.ok());
  EXPECT_THAT(std::string(expired.status().message()),
              HasSubstr("--tls_cert=" + P("expired.pem") + ": the certificate expired on"));
  absl::StatusOr<std::shared_ptr<net::TlsContext>> mismatched = net::TlsContext::ForListener(
      {.cert = P("shim.pem"), .key = P("server.key"), .ca = P("ca-a.pem")});
  ASSERT_FALSE(mismatched.ok());
  EXPECT_THAT(std::string(mismatched.status().message()),
              HasSubstr("the certificate does not match the private key --tls_key=" + P("server.key")));
  absl::StatusOr<std::shared_ptr<net::TlsContext>> missing = net::TlsContext::ForListener(
      {.cert = P("shim.pem"), .key = P("missing.key"), .ca = P("ca-a.pem")});
  ASSERT_FALSE(missing.ok());
  EXPECT_THAT(std::string(missing.status().message()),
              HasSubstr("--tls_key=" + P("missing.key") + ": cannot read it"));
}

TEST_F(ShimTlsTest, Tls11IsRefused) {
  const std::string endpoint = StartShim(ShimTls());
  const std::string s_client =
      absl::StrCat("openssl s_client -connect ", endpoint, " -CAfile ", P("ca-a.pem"), " -cert ",
                   P("server.pem"), " -key ", P("server.key"),
                   " -cipher 'DEFAULT:@SECLEVEL=0' </dev/null 2>&1");
  const testing::CommandResult tls11 = testing::RunCommand(s_client + " -tls1_1");
  EXPECT_NE(tls11.exit_code, 0) << tls11.output;
  EXPECT_THAT(events_.WaitFor("unsupported protocol"), HasSubstr("unsupported protocol"));
  const testing::CommandResult tls12 = testing::RunCommand(s_client + " -tls1_2");
  EXPECT_THAT(tls12.output, HasSubstr("Verify return code: 0 (ok)"));
}

// The shim's files behind a symlink flipped from one version directory to
// the next.
TEST_F(ShimTlsTest, CertificateRotatedByADirectorySwapWhileAConnectionRuns) {
  ASSERT_TRUE(pki_->Issue("next", "a", "board-1", "DNS:board-1-next.riskplan.test", true).ok());
  namespace fs = std::filesystem;
  const fs::path root = P("shim-rotation");
  for (const auto& [version, name] :
       std::vector<std::pair<std::string, std::string>>{{"v1", "shim"}, {"v2", "next"}, {"v3", "expired"}}) {
    fs::create_directories(root / version);
    fs::copy_file(P(name + ".pem"), root / version / "tls.crt");
    fs::copy_file(P(name + ".key"), root / version / "tls.key");
  }
  fs::create_directory_symlink("v1", root / "live");
  const auto flip_to = [&](const char* version) {
    std::error_code ignored;
    fs::remove(root / "live.next", ignored);
    fs::create_directory_symlink(version, root / "live.next");
    fs::rename(root / "live.next", root / "live");
  };
  absl::StatusOr<std::shared_ptr<net::TlsContext>> tls =
      net::TlsContext::ForListener({.cert = (root / "live" / "tls.crt").string(),
                                    .key = (root / "live" / "tls.key").string(),
                                    .ca = P("ca-a.pem")});
  ASSERT_TRUE(tls.ok()) << tls.status();
  const std::string endpoint = StartShim(*tls);
  absl::StatusOr<std::unique_ptr<ShimClient>> running =
      ShimClient::Connect(endpoint, Client("server", "ca-a.pem", "board-1.riskplan.test"));
  ASSERT_TRUE(running.ok()) << running.status();
  flip_to("v2");
  // New connections get the new certificate (looked at once a second, on
  // accept).
  const absl::Time deadline = absl::Now() + absl::Seconds(30);
  absl::StatusOr<std::unique_ptr<ShimClient>> fresh = absl::UnavailableError("not tried");
  while (!fresh.ok() && absl::Now() < deadline) {
    fresh = ShimClient::Connect(endpoint, Client("server", "ca-a.pem", "board-1-next.riskplan.test"));
    if (!fresh.ok()) absl::SleepFor(absl::Milliseconds(200));
  }
  ASSERT_TRUE(fresh.ok()) << fresh.status();
  EXPECT_TRUE((*fresh)->Ping().ok());
  // The connection made before the swap still works.
  EXPECT_TRUE((*running)->Ping().ok());
  // The old name is no longer served.
  absl::StatusOr<std::unique_ptr<ShimClient>> old_name =
      ShimClient::Connect(endpoint, Client("server", "ca-a.pem", "board-1.riskplan.test"));
  ASSERT_FALSE(old_name.ok());
  EXPECT_THAT(std::string(old_name.status().message()), HasSubstr("hostname mismatch"));
  // A swap to an expired certificate is refused: the shim keeps serving the
  // current one, and says so.
  flip_to("v3");
  absl::SleepFor(absl::Milliseconds(1100));
  absl::StatusOr<std::unique_ptr<ShimClient>> after =
      ShimClient::Connect(endpoint, Client("server", "ca-a.pem", "board-1-next.riskplan.test"));
  EXPECT_TRUE(after.ok()) << after.status();
  EXPECT_THAT(events_.WaitFor("do not load"), HasSubstr("the certificate expired on"));
}

}  // namespace
}  // namespace riskplan::accel
