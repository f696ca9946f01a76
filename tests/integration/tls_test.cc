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
#include "tests/integration/tls_fixture.h"

namespace riskplan::testing {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::MatchesRegex;

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

// --- Rotation.

// Certificates under DIR/live, a symlink flipped atomically (rename over it)
// from one version directory to the next, as Kubernetes updates a Secret.
TEST_F(TlsTest, CertificateRotatedByADirectorySwapWhileAStreamRuns) {
  // Both are also for riskplan.test: a rotation must keep a name of the
  // served certificate (BadRotationsAreRefusedAndTheLastGoodPairStaysServed).
  ASSERT_TRUE(pki_->Issue("old", "a", "old.riskplan.test",
                          "DNS:old.riskplan.test,DNS:riskplan.test", true)
                  .ok());
  ASSERT_TRUE(pki_->Issue("new", "a", "new.riskplan.test",
                          "DNS:new.riskplan.test,DNS:riskplan.test", true)
                  .ok());
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
  // gets a certificate for the old name that expires 4 s after it is issued
  // (OpenSSL's validity counts whole seconds; the server takes it only while
  // it is valid, checked within a second of the flip), so the test waits
  // seconds for the expiry instead of keeping a slot of the suite for the
  // 40 s a certificate issued at the start had to stay valid.
  const absl::Time stale_expiry = absl::Now() + absl::Seconds(4);
  ASSERT_TRUE(pki_->Issue("stale", "a", "old.riskplan.test",
                          "DNS:old.riskplan.test,DNS:riskplan.test", true,
                          absl::Now() - absl::Hours(1), stale_expiry)
                  .ok());
  fs::copy_file(P("stale.pem"), root / "v1" / "tls.crt", fs::copy_options::overwrite_existing);
  fs::copy_file(P("stale.key"), root / "v1" / "tls.key", fs::copy_options::overwrite_existing);
  flip_to("v1");
  EXPECT_THAT(WaitForLog(*server, "names=[old.riskplan.test"), HasSubstr("\"event\":\"tls_reloaded\""));
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

// A rotation that would lock every client out (an expired certificate, one
// for none of the served names, a key that does not match) is refused: the
// last good pair stays served to new connections, and the refusal is logged
// with its reason and counted.
TEST_F(TlsTest, BadRotationsAreRefusedAndTheLastGoodPairStaysServed) {
  ASSERT_TRUE(pki_->Issue("elsewhere", "a", "elsewhere.test", "DNS:elsewhere.test", true).ok());
  namespace fs = std::filesystem;
  const fs::path root = P("bad-rotation");
  const auto version = [&](const std::string& name, const std::string& cert,
                           const std::string& key) {
    fs::create_directories(root / name);
    fs::copy_file(P(cert), root / name / "tls.crt", fs::copy_options::overwrite_existing);
    fs::copy_file(P(key), root / name / "tls.key", fs::copy_options::overwrite_existing);
  };
  version("good", "server.pem", "server.key");
  fs::create_directory_symlink("good", root / "live");
  const auto flip_to = [&](const std::string& name) {
    std::error_code ignored;
    fs::remove(root / "live.next", ignored);
    fs::create_directory_symlink(name, root / "live.next");
    fs::rename(root / "live.next", root / "live");
  };
  const std::string live_cert = (root / "live" / "tls.crt").string();
  std::unique_ptr<ServerProcess> server =
      Start({"--tls_cert=" + live_cert, "--tls_key=" + (root / "live" / "tls.key").string(),
             "--tls_reload_s=1"});
  ASSERT_NE(server, nullptr);
  client::ConnectionOptions named = Tls();
  named.tls_server_name = "riskplan.test";

  struct Bad {
    std::string name, cert, key, reason;
  };
  const std::vector<Bad> rotations = {
      {"expired", "expired.pem", "expired.key",
       "--tls_cert=" + live_cert + ": the certificate expired on"},
      {"elsewhere", "elsewhere.pem", "elsewhere.key",
       "--tls_cert=" + live_cert +
           ": the new certificate is for [elsewhere.test], none of the names the served one is "
           "for ([localhost,riskplan.test,127.0.0.1])"},
      {"mismatch", "server.pem", "server-other.key",
       "the certificate does not match the private key"},
  };
  int refused = 0;
  for (const Bad& bad : rotations) {
    SCOPED_TRACE(bad.name);
    version(bad.name, bad.cert, bad.key);
    flip_to(bad.name);
    ++refused;
    const std::string log =
        WaitForLog(*server, absl::StrCat("\"event\":\"tls_reload_refused\",\"detail\":\"refused=", refused));
    EXPECT_THAT(log, HasSubstr(absl::StrCat("refused=", refused)));
    EXPECT_THAT(log, HasSubstr(bad.reason));
    // Give gRPC's provider time to re-read (it would have taken the bad
    // files by now), then a new connection still gets the good pair.
    absl::SleepFor(absl::Seconds(2));
    client::RiskplanClient c = Client(*server, named);
    const grpc::Status ping = c.Ping(absl::Seconds(10));
    EXPECT_TRUE(ping.ok()) << ping.error_message();
  }
  // A good rotation after the refused ones is taken.
  ASSERT_TRUE(pki_->Issue("renewed", "a", "riskplan.test", "DNS:riskplan.test", true).ok());
  version("renewed", "renewed.pem", "renewed.key");
  flip_to("renewed");
  EXPECT_THAT(WaitForLog(*server, "\"event\":\"tls_reloaded\""),
              HasSubstr("names=[riskplan.test]"));
}

}  // namespace
}  // namespace riskplan::testing
