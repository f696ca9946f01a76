// The refusal matrix of the gRPC port: the real riskplan-server with TLS,
// mutual TLS, revocation lists and tokens, and the real client library's
// channel (client::MakeChannel, what `riskplan` uses), with every
// certificate made at test time by the openssl CLI (tests/integration/
// test_pki.sh). Each case checks the exact status code and the words of the
// message (or of the server's log, for what gRPC tells only there), never
// the machine's speed.
#include <filesystem>
#include <regex>
#include <thread>

#include "absl/strings/str_cat.h"
#include "absl/synchronization/notification.h"
#include "absl/time/clock.h"
#include "client/client.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/integration/requests.h"
#include "tests/integration/server_process.h"
#include "tests/integration/test_pki.h"

namespace riskplan::testing {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::MatchesRegex;

constexpr char kViewerToken[] = "viewer-token-3f9a";
constexpr char kPlannerToken[] = "planner-token-77c1";
constexpr char kOperatorToken[] = "operator-token-e0b2";

// What the token file lists for `token` (sha256sum's digest).
std::string Sha256Hex(const std::string& token) {
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

  static TestPki* pki_;
};
TestPki* TlsTest::pki_ = nullptr;

// --- Start-up refusals: gRPC 1.51 would start and fail every handshake.

TEST_F(TlsTest, RefusesToStartWithAMissingKeyNamingTheFile) {
  // (Root reads a chmod 000 file: a missing path stands for an unreadable key.)
  absl::StatusOr<std::unique_ptr<ServerProcess>> server = ServerProcess::Start(
      {"--tls_cert=" + P("server.pem"), "--tls_key=" + P("no-such.key")});
  ASSERT_FALSE(server.ok());
  EXPECT_THAT(std::string(server.status().message()),
              AllOf(HasSubstr("exited before serving"),
                    HasSubstr("cannot start: --tls_key=" + P("no-such.key") + ": cannot read it")));
}

TEST_F(TlsTest, RefusesToStartWithAKeyThatDoesNotMatchTheCertificate) {
  absl::StatusOr<std::unique_ptr<ServerProcess>> server = ServerProcess::Start(
      {"--tls_cert=" + P("server.pem"), "--tls_key=" + P("server-other.key")});
  ASSERT_FALSE(server.ok());
  EXPECT_THAT(std::string(server.status().message()),
              HasSubstr("--tls_cert=" + P("server.pem") +
                        ": the certificate does not match the private key --tls_key=" +
                        P("server-other.key")));
}

TEST_F(TlsTest, RefusesToStartWithABrokenKey) {
  WriteFile("broken.key", "-----BEGIN PRIVATE KEY-----\nbm90IGEga2V5\n-----END PRIVATE KEY-----\n");
  absl::StatusOr<std::unique_ptr<ServerProcess>> server = ServerProcess::Start(
      {"--tls_cert=" + P("server.pem"), "--tls_key=" + P("broken.key")});
  ASSERT_FALSE(server.ok());
  EXPECT_THAT(std::string(server.status().message()),
              HasSubstr("--tls_key=" + P("broken.key") + ": not a PEM private key"));
}

TEST_F(TlsTest, RefusesToStartWithAnExpiredCertificate) {
  absl::StatusOr<std::unique_ptr<ServerProcess>> server = ServerProcess::Start(
      {"--tls_cert=" + P("expired.pem"), "--tls_key=" + P("expired.key")});
  ASSERT_FALSE(server.ok());
  EXPECT_THAT(std::string(server.status().message()),
              HasSubstr("--tls_cert=" + P("expired.pem") + ": the certificate expired on"));
}

TEST_F(TlsTest, RefusesPlaintextOnANonLoopbackAddressUnlessAskedFor) {
  absl::StatusOr<std::unique_ptr<ServerProcess>> server =
      ServerProcess::Start({"--listen=0.0.0.0:0"});
  ASSERT_FALSE(server.ok());
  EXPECT_THAT(std::string(server.status().message()),
              HasSubstr("is not a loopback address and no --tls_cert/--tls_key were given"));
  std::unique_ptr<ServerProcess> asked = Start({"--listen=0.0.0.0:0", "--allow_plaintext"});
  ASSERT_NE(asked, nullptr);
}

// --- Handshakes.

TEST_F(TlsTest, PlaintextClientToTlsServerIsRefused) {
  std::unique_ptr<ServerProcess> server = Start(TlsFlags());
  ASSERT_NE(server, nullptr);
  client::RiskplanClient plain = Client(*server, {});
  const grpc::Status status = ListMaps(plain);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE) << status.error_message();
  EXPECT_THAT(client::ExplainStatus(status, {}),
              HasSubstr("if the server speaks TLS, give --tls_ca"));
  // And the same server serves a TLS client.
  client::RiskplanClient tls = Client(*server, Tls());
  EXPECT_TRUE(ListMaps(tls).ok());
}

TEST_F(TlsTest, TlsClientToPlaintextServerIsRefused) {
  std::unique_ptr<ServerProcess> server = Start({});
  ASSERT_NE(server, nullptr);
  client::RiskplanClient tls = Client(*server, Tls());
  const grpc::Status status = ListMaps(tls);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_THAT(status.error_message(), HasSubstr("Ssl handshake failed"));
  EXPECT_THAT(client::ExplainStatus(status, Tls()),
              HasSubstr("is the server speaking plaintext"));
}

TEST_F(TlsTest, ServerCertificateFromAnotherCaIsRefusedByTheClient) {
  std::unique_ptr<ServerProcess> server = Start(TlsFlags());
  ASSERT_NE(server, nullptr);
  client::ConnectionOptions other_ca = Tls();
  other_ca.tls_ca = P("ca-b.pem");
  client::RiskplanClient c = Client(*server, other_ca);
  const grpc::Status status = ListMaps(c);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_THAT(status.error_message(), HasSubstr("certificate verify failed"));
  EXPECT_THAT(client::ExplainStatus(status, other_ca),
              HasSubstr("this client refused the server's certificate: it is not signed by"));
}

TEST_F(TlsTest, WrongServerNameIsRefusedByTheClient) {
  std::unique_ptr<ServerProcess> server = Start(TlsFlags());
  ASSERT_NE(server, nullptr);
  client::ConnectionOptions other_name = Tls();
  other_name.tls_server_name = "other.test";
  client::RiskplanClient c = Client(*server, other_name);
  const grpc::Status status = ListMaps(c);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_THAT(status.error_message(), HasSubstr("Peer name other.test is not in peer certificate"));
  EXPECT_THAT(client::ExplainStatus(status, other_name), HasSubstr("not for the name asked"));
  // The name the certificate carries is accepted through the same flag.
  client::ConnectionOptions right_name = Tls();
  right_name.tls_server_name = "riskplan.test";
  client::RiskplanClient ok = Client(*server, right_name);
  EXPECT_TRUE(ListMaps(ok).ok());
}

TEST_F(TlsTest, MissingClientCertificateUnderMutualTlsIsRefusedAndLoggedWithThePeer) {
  std::unique_ptr<ServerProcess> server = Start(MutualFlags());
  ASSERT_NE(server, nullptr);
  client::RiskplanClient c = Client(*server, Tls());
  const grpc::Status status = ListMaps(c);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE);
  // The server sends no alert: the client sees a closed connection only.
  EXPECT_THAT(client::ExplainStatus(status, Tls()),
              HasSubstr("the server may require a client certificate"));
  const std::string log = WaitForLog(*server, "peer did not return a certificate");
  EXPECT_THAT(log, MatchesRegex("(.|\n)*\"event\":\"tls_handshake_failed\",\"detail\":\"reason=\\\\\""
                                "[^\n]*peer did not return a certificate[^\n]*peer=ipv4:127\\.0\\.0\\.1:"
                                "[0-9]+ (.|\n)*"));
  client::RiskplanClient mutual = Client(*server, Mutual("client"));
  EXPECT_TRUE(ListMaps(mutual).ok());
}

TEST_F(TlsTest, ClientCertificateFromAnotherCaIsRefused) {
  std::unique_ptr<ServerProcess> server = Start(MutualFlags());
  ASSERT_NE(server, nullptr);
  client::RiskplanClient c = Client(*server, Mutual("rogue"));
  const grpc::Status status = ListMaps(c);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_THAT(client::ExplainStatus(status, Mutual("rogue")),
              HasSubstr("the server refused this client's certificate"));
  // gRPC names the reason as "certificate verify failed" (with the X509
  // code when it logs one), and the acceptor adds the peer.
  EXPECT_THAT(WaitForLog(*server, "certificate"),
              MatchesRegex("(.|\n)*\"event\":\"tls_handshake_failed\",\"detail\":\"reason=[^\n]*"
                           "(certificate verify failed|unable to get local issuer certificate)"
                           "[^\n]*peer=ipv4:127\\.0\\.0\\.1:[0-9]+ (.|\n)*"));
}

TEST_F(TlsTest, RevokedClientCertificateIsRefused) {
  std::unique_ptr<ServerProcess> server = Start(MutualFlags({"--tls_crl_dir=" + P("crl-a")}));
  ASSERT_NE(server, nullptr);
  client::RiskplanClient revoked = Client(*server, Mutual("revoked"));
  const grpc::Status status = ListMaps(revoked);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_THAT(WaitForLog(*server, "certificate revoked (X509 code 23)"),
              HasSubstr("client certificate: certificate revoked (X509 code 23)"));
  // A certificate of the same CA that is not on the list is served.
  client::RiskplanClient good = Client(*server, Mutual("client"));
  EXPECT_TRUE(ListMaps(good).ok());
}

TEST_F(TlsTest, Tls11IsRefusedEvenFromAClientThatOffersIt) {
  std::unique_ptr<ServerProcess> server = Start(TlsFlags());
  ASSERT_NE(server, nullptr);
  // SECLEVEL=0: Debian's OpenSSL would otherwise refuse TLS 1.1 on the
  // client side, before the server is asked.
  const std::string s_client = absl::StrCat(
      "openssl s_client -connect ", server->address(), " -CAfile ", P("ca-a.pem"),
      " -cipher 'DEFAULT:@SECLEVEL=0' </dev/null 2>&1");
  const CommandResult tls11 = RunCommand(s_client + " -tls1_1", absl::Minutes(1));
  EXPECT_NE(tls11.exit_code, 0) << tls11.output;
  EXPECT_THAT(tls11.output, AllOf(HasSubstr("no peer certificate available"),
                                  HasSubstr("Cipher is (NONE)")));
  EXPECT_THAT(WaitForLog(*server, "unsupported protocol"),
              HasSubstr("\"event\":\"tls_handshake_failed\""));
  // The same command with TLS 1.2 completes its handshake.
  const CommandResult tls12 =
      RunCommand(absl::StrCat("openssl s_client -connect ", server->address(), " -CAfile ",
                              P("ca-a.pem"), " -cipher 'DEFAULT:@SECLEVEL=0' -tls1_2 </dev/null 2>&1"),
                 absl::Minutes(1));
  EXPECT_THAT(tls12.output, HasSubstr("Verify return code: 0 (ok)"));
}

// --- Tokens and roles.

TEST_F(TlsTest, MissingTokenIsUnauthenticated) {
  std::unique_ptr<ServerProcess> server = Start(TlsFlags({"--token_file=" + P("tokens.txt")}));
  ASSERT_NE(server, nullptr);
  client::RiskplanClient c = Client(*server, Tls());
  const grpc::Status status = ListMaps(c);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(status.error_message(), "this server requires a bearer token (riskplan --token_file=FILE)");
  EXPECT_THAT(WaitForLog(*server, "token_refused"), HasSubstr("\"event\":\"token_refused\""));
}

TEST_F(TlsTest, WrongTokenIsUnauthenticatedAndNeverLogged) {
  std::unique_ptr<ServerProcess> server = Start(TlsFlags({"--token_file=" + P("tokens.txt")}));
  ASSERT_NE(server, nullptr);
  client::RiskplanClient c = Client(*server, Tls("unknown"));
  const grpc::Status status = ListMaps(c);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_THAT(status.error_message(), HasSubstr("not one this server knows"));
  const std::string log = WaitForLog(*server, "token_refused");
  EXPECT_THAT(log, ::testing::Not(HasSubstr("not-a-token-this-server-knows")));
}

TEST_F(TlsTest, RoleThatMayNotCallTheMethodIsPermissionDenied) {
  std::unique_ptr<ServerProcess> server =
      Start(MutualFlags({"--token_file=" + P("tokens.txt"), "--metrics_listen=127.0.0.1:0"}));
  ASSERT_NE(server, nullptr);
  client::RiskplanClient viewer = Client(*server, Mutual("client", "viewer"));
  // A viewer evaluates...
  v1::EvaluateRiskResponse evaluation;
  EXPECT_TRUE(viewer.EvaluateRisk(SmallCityPolyline(), &evaluation).ok());
  // ...but may not plan nor load-test.
  PlanOutcome plan = RunPlan(viewer, SmallCityPlan(0, 50));
  EXPECT_EQ(plan.status.error_code(), grpc::StatusCode::PERMISSION_DENIED);
  EXPECT_EQ(plan.status.error_message(),
            "alice has role viewer; PlanTrajectory needs role planner or above");
  const grpc::Status ping = viewer.Ping();
  EXPECT_EQ(ping.error_code(), grpc::StatusCode::PERMISSION_DENIED);
  EXPECT_EQ(ping.error_message(), "alice has role viewer; Ping needs role operator or above");
  // A planner plans; an operator pings.
  client::RiskplanClient planner = Client(*server, Mutual("client", "planner"));
  EXPECT_TRUE(RunPlan(planner, SmallCityPlan(0, 50)).status.ok());
  client::RiskplanClient op = Client(*server, Mutual("client", "operator"));
  EXPECT_TRUE(op.Ping().ok());
  // The identity is in the RPC log line (never the token), and a label.
  const std::string log = WaitForLog(*server, "\"identity\":\"olga\"");
  EXPECT_THAT(log, HasSubstr("\"method\":\"PlanTrajectory\",\"code\":\"PERMISSION_DENIED\""));
  EXPECT_THAT(log, HasSubstr("\"identity\":\"alice\""));
  EXPECT_THAT(log, ::testing::Not(HasSubstr(kViewerToken)));
  absl::StatusOr<std::string> metrics = HttpGet(MetricsAddress(log), "/metrics");
  ASSERT_TRUE(metrics.ok()) << metrics.status();
  EXPECT_EQ(MetricValue(*metrics, "riskplan_rpcs_by_identity_total{code=\"PERMISSION_DENIED\","
                                  "identity=\"alice\",method=\"Ping\"}"),
            1.0);
  EXPECT_EQ(MetricValue(*metrics, "riskplan_rpcs_by_identity_total{code=\"OK\","
                                  "identity=\"paul\",method=\"PlanTrajectory\"}"),
            1.0);
}

TEST_F(TlsTest, ClientCertificateSubjectNamesACallerWithoutToken) {
  std::unique_ptr<ServerProcess> server = Start(MutualFlags());
  ASSERT_NE(server, nullptr);
  client::RiskplanClient c = Client(*server, Mutual("client"));
  ASSERT_TRUE(c.Ping().ok());
  EXPECT_THAT(WaitForLog(*server, "\"identity\":\"x509:"),
              HasSubstr("\"identity\":\"x509:CN=ground-1"));
}

TEST_F(TlsTest, TokensAreCheckedOnAPlaintextLoopbackPortToo) {
  // No AuthMetadataProcessor there (gRPC aborts with one on plaintext): the
  // handlers' own check.
  std::unique_ptr<ServerProcess> server = Start({"--token_file=" + P("tokens.txt")});
  ASSERT_NE(server, nullptr);
  client::ConnectionOptions none;
  client::RiskplanClient anonymous = Client(*server, none);
  EXPECT_EQ(ListMaps(anonymous).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  client::ConnectionOptions unknown;
  unknown.token_file = P("unknown.token");
  client::RiskplanClient stranger = Client(*server, unknown);
  EXPECT_EQ(ListMaps(stranger).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  client::ConnectionOptions viewer_token;
  viewer_token.token_file = P("viewer.token");
  client::RiskplanClient viewer = Client(*server, viewer_token);
  EXPECT_TRUE(ListMaps(viewer).ok());
  EXPECT_EQ(viewer.Ping().error_code(), grpc::StatusCode::PERMISSION_DENIED);
  client::ConnectionOptions operator_token;
  operator_token.token_file = P("operator.token");
  client::RiskplanClient op = Client(*server, operator_token);
  EXPECT_TRUE(op.Ping().ok());
}

TEST_F(TlsTest, AViewerMayNotPlanAFleetAndAPlannerMay) {
  std::unique_ptr<ServerProcess> server = Start({"--token_file=" + P("tokens.txt")});
  ASSERT_NE(server, nullptr);
  v1::FleetRequest fleet;
  v1::FleetMission* mission = fleet.add_missions();
  mission->set_id("m");
  *mission->mutable_request() = SmallCityPlan(0, 50);
  const auto run = [&](const std::string& token) {
    client::ConnectionOptions options;
    options.token_file = P(token + ".token");
    client::RiskplanClient c = Client(*server, options);
    int finals = 0;
    const grpc::Status status = c.PlanFleet(fleet, [&](const v1::FleetUpdate& u) {
      finals += u.update().final() ? 1 : 0;
      return true;
    });
    return std::pair{status, finals};
  };
  const auto [refused, none] = run("viewer");
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::PERMISSION_DENIED);
  EXPECT_EQ(refused.error_message(),
            "alice has role viewer; PlanFleet needs role planner or above");
  EXPECT_EQ(none, 0);
  const auto [planned, finals] = run("planner");
  EXPECT_TRUE(planned.ok()) << planned.error_message();
  EXPECT_EQ(finals, 1);
}

TEST_F(TlsTest, HealthIsOpenOnItsPlaintextPortAndOnTheTlsPort) {
  std::unique_ptr<ServerProcess> server =
      Start(MutualFlags({"--token_file=" + P("tokens.txt"), "--health_listen=127.0.0.1:0"}));
  ASSERT_NE(server, nullptr);
  std::smatch match;
  const std::string log = server->Stderr();
  ASSERT_TRUE(std::regex_search(
      log, match, std::regex("\"event\":\"health_listening\",\"detail\":\"([0-9.:]+)\"")))
      << log;
  client::RiskplanClient probe(match[1].str());  // plaintext, no token: a kubelet
  grpc::health::v1::HealthCheckResponse::ServingStatus status{};
  ASSERT_TRUE(probe.CheckHealth("", &status).ok());
  EXPECT_EQ(status, grpc::health::v1::HealthCheckResponse::SERVING);
  // Only health is served there.
  EXPECT_EQ(ListMaps(probe).error_code(), grpc::StatusCode::UNIMPLEMENTED);
  // On the TLS port health needs no token either.
  client::RiskplanClient c = Client(*server, Mutual("client"));
  ASSERT_TRUE(c.CheckHealth("riskplan.v1.Planner", &status).ok());
  EXPECT_EQ(status, grpc::health::v1::HealthCheckResponse::SERVING);
}

// --- The shim link, end to end: the real riskplan-fpga-shim and server.

TEST_F(TlsTest, ShimRefusesPlaintextOffLoopbackAndTlsWithoutAClientCa) {
  absl::StatusOr<std::unique_ptr<ServerProcess>> plaintext =
      ServerProcess::StartShim({"--device=model", "--listen=0.0.0.0:0"});
  ASSERT_FALSE(plaintext.ok());
  EXPECT_THAT(std::string(plaintext.status().message()),
              HasSubstr("--listen is not a loopback address and no --tls_cert"));
  absl::StatusOr<std::unique_ptr<ServerProcess>> one_way = ServerProcess::StartShim(
      {"--device=model", "--tls_cert=" + P("server.pem"), "--tls_key=" + P("server.key")});
  ASSERT_FALSE(one_way.ok());
  EXPECT_THAT(std::string(one_way.status().message()),
              HasSubstr("--tls_client_ca is required with TLS: the shim must authenticate the server"));
  absl::StatusOr<std::unique_ptr<ServerProcess>> expired = ServerProcess::StartShim(
      {"--device=model", "--tls_cert=" + P("expired.pem"), "--tls_key=" + P("expired.key"),
       "--tls_client_ca=" + P("ca-a.pem")});
  ASSERT_FALSE(expired.ok());
  EXPECT_THAT(std::string(expired.status().message()),
              HasSubstr("--tls_cert=" + P("expired.pem") + ": the certificate expired on"));
}

TEST_F(TlsTest, ServerEvaluatesThroughAShimOverMutualTlsAndTheShimRefusesAServerWithoutCertificate) {
  // server.pem is for 127.0.0.1 too: it serves as the shim's certificate.
  auto shim = ServerProcess::StartShim({"--device=model", "--tls_cert=" + P("server.pem"),
                                        "--tls_key=" + P("server.key"),
                                        "--tls_client_ca=" + P("ca-a.pem")});
  ASSERT_TRUE(shim.ok()) << shim.status();
  std::unique_ptr<ServerProcess> server =
      Start({"--fpga_shims=" + (*shim)->address(), "--cpu_workers=0", "--accel_caller_runs=false",
             "--fpga_tls_ca=" + P("ca-a.pem"), "--fpga_tls_cert=" + P("client.pem"),
             "--fpga_tls_key=" + P("client.key")});
  ASSERT_NE(server, nullptr);
  // The worker's handshake and known-answer batch, over TLS.
  const std::string up = "probing\\\",\\\"to\\\":\\\"up";
  ASSERT_THAT(WaitForLog(*server, up), HasSubstr(up));
  // Only the board computes (no CPU workers, callers do not run chunks).
  client::RiskplanClient c = Client(*server, {});
  v1::EvaluateRiskResponse response;
  const grpc::Status status = c.EvaluateRisk(SmallCityPolyline(), &response, absl::Seconds(60));
  EXPECT_TRUE(status.ok()) << status.error_message();
  EXPECT_GT(response.risk(), 0.0);

  // A server with the shim's CA but no certificate of its own is refused by
  // the shim, which says so; the server's worker says why.
  std::unique_ptr<ServerProcess> anonymous =
      Start({"--fpga_shims=" + (*shim)->address(), "--cpu_workers=0",
             "--fpga_tls_ca=" + P("ca-a.pem")});
  ASSERT_NE(anonymous, nullptr);
  EXPECT_THAT(WaitForLog(*anonymous, "certificate required"),
              HasSubstr("probe failed: shim " + (*shim)->address()));
  EXPECT_THAT(WaitForLog(**shim, "peer did not return a certificate"),
              HasSubstr("refused 127.0.0.1:"));
}

// --- Rotation.

// Certificates under DIR/live, a symlink flipped atomically (rename over it)
// from one version directory to the next, as Kubernetes updates a Secret.
TEST_F(TlsTest, CertificateRotatedByADirectorySwapWhileAStreamRuns) {
  ASSERT_TRUE(pki_->Issue("old", "a", "old.riskplan.test", "DNS:old.riskplan.test", true).ok());
  ASSERT_TRUE(pki_->Issue("new", "a", "new.riskplan.test", "DNS:new.riskplan.test", true).ok());
  namespace fs = std::filesystem;
  const fs::path root = P("rotation");
  fs::create_directories(root / "v1");
  fs::create_directories(root / "v2");
  fs::copy_file(P("old.pem"), root / "v1" / "tls.crt");
  fs::copy_file(P("old.key"), root / "v1" / "tls.key");
  fs::copy_file(P("new.pem"), root / "v2" / "tls.crt");
  fs::copy_file(P("new.key"), root / "v2" / "tls.key");
  fs::create_directory_symlink("v1", root / "live");
  const auto flip_to = [&](const char* version) {
    std::error_code ignored;
    fs::remove(root / "live.next", ignored);
    fs::create_directory_symlink(version, root / "live.next");
    fs::rename(root / "live.next", root / "live");  // rename(2): atomic
  };
  std::unique_ptr<ServerProcess> server =
      Start({"--tls_cert=" + (root / "live" / "tls.crt").string(),
             "--tls_key=" + (root / "live" / "tls.key").string(), "--tls_reload_s=1"});
  ASSERT_NE(server, nullptr);
  const auto named = [&](const std::string& name) {
    client::ConnectionOptions o = Tls();
    o.tls_server_name = name;
    return o;
  };

  // A stream on the old certificate, running across the swap.
  client::RiskplanClient streaming = Client(*server, named("old.riskplan.test"));
  absl::Notification first_update;
  grpc::Status stream_status;
  bool stream_ended_with_final = false;
  std::thread stream([&] {
    stream_status = streaming.Plan(SmallCityPlan(4000, 0), [&](const v1::PlanUpdate& u) {
      if (!first_update.HasBeenNotified()) first_update.Notify();
      stream_ended_with_final = u.final();
      return true;
    });
  });
  ASSERT_TRUE(first_update.WaitForNotificationWithTimeout(absl::Seconds(60)));
  flip_to("v2");

  // New connections get the new certificate once it is re-read.
  const absl::Time deadline = absl::Now() + absl::Seconds(60);
  grpc::Status fresh;
  do {
    client::RiskplanClient c = Client(*server, named("new.riskplan.test"));
    fresh = c.Ping(absl::Seconds(10));
    if (!fresh.ok()) absl::SleepFor(absl::Milliseconds(200));
  } while (!fresh.ok() && absl::Now() < deadline);
  EXPECT_TRUE(fresh.ok()) << fresh.error_message();
  client::RiskplanClient old_name = Client(*server, named("old.riskplan.test"));
  const grpc::Status refused = old_name.Ping(absl::Seconds(10));
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_THAT(refused.error_message(), HasSubstr("Peer name old.riskplan.test is not in peer certificate"));

  // The stream that started on the old certificate ends normally.
  stream.join();
  EXPECT_TRUE(stream_status.ok()) << stream_status.error_message();
  EXPECT_TRUE(stream_ended_with_final);

  // Once the old name's certificate has expired, it is refused even if it is
  // served again (a rotation rolled back too late). The rollback directory
  // gets a certificate for the old name that expires 2 s after it is issued
  // (OpenSSL's validity counts whole seconds), so the test waits seconds for
  // the expiry instead of keeping a slot of the suite for the 40 s a
  // certificate issued at the start had to stay valid.
  const absl::Time stale_expiry = absl::Now() + absl::Seconds(2);
  ASSERT_TRUE(pki_->Issue("stale", "a", "old.riskplan.test", "DNS:old.riskplan.test", true,
                          absl::Now() - absl::Hours(1), stale_expiry)
                  .ok());
  fs::copy_file(P("stale.pem"), root / "v1" / "tls.crt", fs::copy_options::overwrite_existing);
  fs::copy_file(P("stale.key"), root / "v1" / "tls.key", fs::copy_options::overwrite_existing);
  flip_to("v1");
  absl::SleepFor(std::max(absl::ZeroDuration(), stale_expiry + absl::Seconds(1) - absl::Now()));
  grpc::Status expired;
  const absl::Time second_deadline = absl::Now() + absl::Seconds(60);
  do {
    client::RiskplanClient c = Client(*server, named("old.riskplan.test"));
    expired = c.Ping(absl::Seconds(10));
    if (expired.error_message().find("certificate verify failed") != std::string::npos) break;
    absl::SleepFor(absl::Milliseconds(200));
  } while (absl::Now() < second_deadline);
  EXPECT_EQ(expired.error_code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_THAT(expired.error_message(), HasSubstr("certificate verify failed"));
}

}  // namespace
}  // namespace riskplan::testing
