// The fixture of the gRPC port's refusal matrix (tls_test.cc: certificates,
// handshakes and rotation; tls_auth_test.cc: tokens, roles, health and the
// shim link): the real riskplan-server and the real client library's channel,
// with every certificate made at test time by the openssl CLI
// (tests/integration/test_pki.sh) and a token file of three roles.
#ifndef RISKPLAN_TESTS_INTEGRATION_TLS_FIXTURE_H_
#define RISKPLAN_TESTS_INTEGRATION_TLS_FIXTURE_H_

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "client/client.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/integration/server_process.h"
#include "tests/integration/test_pki.h"

namespace riskplan::testing {

inline constexpr char kViewerToken[] = "viewer-token-3f9a";
inline constexpr char kPlannerToken[] = "planner-token-77c1";
inline constexpr char kOperatorToken[] = "operator-token-e0b2";

// What the token file lists for `token` (sha256sum's digest).
inline std::string Sha256Hex(const std::string& token) {
  const CommandResult r = RunCommand(absl::StrCat("printf %s '", token, "' | sha256sum"));
  return r.output.substr(0, 64);
}

// The PKI and token files every test shares (made once: key generation is
// the slow part).
class TlsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // These tests choose every server's security themselves: the suite-wide
    // switch (tests/integration/server_process.h) would change their meaning.
    unsetenv("RISKPLAN_TEST_SECURITY");
    absl::StatusOr<std::unique_ptr<TestPki>> pki = TestPki::Create();
    ASSERT_TRUE(pki.ok()) << pki.status();
    pki_ = pki->release();
    const std::string server_san = "DNS:localhost,DNS:riskplan.test,IP:127.0.0.1";
    ASSERT_TRUE(pki_->Issue("server", "a", "riskplan.test", server_san, true).ok());
    ASSERT_TRUE(pki_->Issue("expired", "a", "riskplan.test", server_san, true,
                            absl::Now() - absl::Hours(48), absl::Now() - absl::Hours(24))
                    .ok());
    ASSERT_TRUE(pki_->Mismatch("server").ok());
    ASSERT_TRUE(pki_->Issue("client", "a", "ground-1", "", false).ok());
    ASSERT_TRUE(pki_->Issue("rogue", "b", "rogue-1", "", false).ok());
    ASSERT_TRUE(pki_->Issue("revoked", "a", "revoked-1", "", false).ok());
    ASSERT_TRUE(pki_->Revoke("revoked", "a").ok());
    WriteFile("tokens.txt", absl::StrCat("# hash identity role\n",
                                          Sha256Hex(kViewerToken), " alice viewer\n",
                                          Sha256Hex(kPlannerToken), " paul planner\n",
                                          Sha256Hex(kOperatorToken), " olga operator\n"));
    WriteFile("viewer.token", absl::StrCat(kViewerToken, "\n"));
    WriteFile("planner.token", kPlannerToken);
    WriteFile("operator.token", kOperatorToken);
    WriteFile("unknown.token", "not-a-token-this-server-knows");
  }
  static void TearDownTestSuite() {
    delete pki_;
    pki_ = nullptr;
  }

  static void WriteFile(const std::string& name, const std::string& text) {
    std::FILE* f = std::fopen(pki_->Path(name).c_str(), "w");
    ASSERT_NE(f, nullptr);
    std::fputs(text.c_str(), f);
    std::fclose(f);
  }
  static std::string P(const std::string& name) { return pki_->Path(name); }

  // Server flags: TLS with server.pem, plus `extra`.
  static std::vector<std::string> TlsFlags(std::vector<std::string> extra = {}) {
    std::vector<std::string> flags = {"--tls_cert=" + P("server.pem"),
                                      "--tls_key=" + P("server.key")};
    flags.insert(flags.end(), extra.begin(), extra.end());
    return flags;
  }
  static std::vector<std::string> MutualFlags(std::vector<std::string> extra = {}) {
    extra.push_back("--tls_client_ca=" + P("ca-a.pem"));
    return TlsFlags(std::move(extra));
  }

  static std::unique_ptr<ServerProcess> Start(std::vector<std::string> flags) {
    absl::StatusOr<std::unique_ptr<ServerProcess>> server = ServerProcess::Start(std::move(flags));
    EXPECT_TRUE(server.ok()) << server.status();
    return server.ok() ? *std::move(server) : nullptr;
  }

  // A client of `server` with `options`, on a connection of its own (no
  // subchannel shared with another client of the test).
  static client::RiskplanClient Client(const ServerProcess& server,
                                       const client::ConnectionOptions& options) {
    grpc::ChannelArguments own;
    own.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
    absl::StatusOr<std::shared_ptr<grpc::Channel>> channel =
        client::MakeChannel(server.address(), options, own);
    EXPECT_TRUE(channel.ok()) << channel.status();
    return client::RiskplanClient(*channel);
  }
  static client::ConnectionOptions Tls(std::string token = "") {
    client::ConnectionOptions o;
    o.tls_ca = P("ca-a.pem");
    if (!token.empty()) o.token_file = P(token + ".token");
    return o;
  }
  static client::ConnectionOptions Mutual(const std::string& cert, std::string token = "") {
    client::ConnectionOptions o = Tls(std::move(token));
    o.tls_cert = P(cert + ".pem");
    o.tls_key = P(cert + ".key");
    return o;
  }

  static grpc::Status ListMaps(client::RiskplanClient& c) {
    v1::ListMapsResponse response;
    return c.ListMaps(&response, absl::Seconds(20));
  }

  // Waits until the server's log contains `text` (a log line may follow the
  // client's error by a moment); the log.
  static std::string WaitForLog(const ServerProcess& server, const std::string& text) {
    const absl::Time deadline = absl::Now() + absl::Seconds(20);
    std::string log = server.Stderr();
    while (log.find(text) == std::string::npos && absl::Now() < deadline) {
      absl::SleepFor(absl::Milliseconds(50));
      log = server.Stderr();
    }
    return log;
  }

  static inline TestPki* pki_ = nullptr;
};

}  // namespace riskplan::testing

#endif  // RISKPLAN_TESTS_INTEGRATION_TLS_FIXTURE_H_
