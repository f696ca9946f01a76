// The refusal matrix of the gRPC port, continued (tls_test.cc has the
// certificates, handshakes and rotation): tokens and roles on the TLS port and
// on a plaintext loopback port, health on its own port, and the FPGA shim link
// over mutual TLS. Each case checks the exact status code and the words of the
// message (or of the server's log), never the machine's speed.
#include <filesystem>
#include <regex>
#include <thread>

#include "absl/strings/str_cat.h"
#include "absl/synchronization/notification.h"
#include "absl/time/clock.h"
#include "client/client.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/integration/reflection_probe.h"
#include "tests/integration/requests.h"
#include "tests/integration/server_process.h"
#include "tests/integration/tls_fixture.h"

namespace riskplan::testing {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::MatchesRegex;
using ::testing::Not;

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

// --- Server reflection: a viewer method, never open without a token where
// tokens are asked for, and never on the health port.

TEST_F(TlsTest, TheHealthPortServesNoReflection) {
  std::unique_ptr<ServerProcess> server =
      Start(MutualFlags({"--token_file=" + P("tokens.txt"), "--health_listen=127.0.0.1:0"}));
  ASSERT_NE(server, nullptr);
  std::smatch match;
  const std::string log = server->Stderr();
  ASSERT_TRUE(std::regex_search(
      log, match, std::regex("\"event\":\"health_listening\",\"detail\":\"([0-9.:]+)\"")))
      << log;
  client::RiskplanClient probe(match[1].str());
  const ReflectionAnswer listed = AskReflection(probe.channel());
  EXPECT_EQ(listed.status.error_code(), grpc::StatusCode::UNIMPLEMENTED)
      << listed.status.error_message();
  EXPECT_THAT(listed.response, Not(HasSubstr("riskplan.v1.Planner")));
  const ReflectionAnswer file = AskReflection(probe.channel(), "riskplan.v1.Planner");
  EXPECT_EQ(file.status.error_code(), grpc::StatusCode::UNIMPLEMENTED);
  EXPECT_THAT(file.response, Not(HasSubstr("PlanTrajectory")));
}

TEST_F(TlsTest, ReflectionOnTheTlsPortNeedsAToken) {
  std::unique_ptr<ServerProcess> server = Start(TlsFlags({"--token_file=" + P("tokens.txt")}));
  ASSERT_NE(server, nullptr);
  const ReflectionAnswer refused = AskReflection(Client(*server, Tls()).channel());
  EXPECT_EQ(refused.status.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_THAT(refused.response, Not(HasSubstr("riskplan.v1.Planner")));
  const ReflectionAnswer viewer = AskReflection(Client(*server, Tls("viewer")).channel());
  EXPECT_TRUE(viewer.status.ok()) << viewer.status.error_message();
  EXPECT_THAT(viewer.response, HasSubstr("riskplan.v1.Planner"));
}

TEST_F(TlsTest, ReflectionOnAPlaintextPortNeedsATokenToo) {
  std::unique_ptr<ServerProcess> server = Start({"--token_file=" + P("tokens.txt")});
  ASSERT_NE(server, nullptr);
  client::ConnectionOptions no_token;
  for (const ReflectionAnswer& answer :
       {AskReflection(Client(*server, no_token).channel()),
        AskReflection(Client(*server, no_token).channel(), "riskplan.v1.Planner")}) {
    EXPECT_EQ(answer.status.error_code(), grpc::StatusCode::UNAUTHENTICATED)
        << answer.status.error_message();
    EXPECT_EQ(answer.status.error_message(),
              "this server requires a bearer token (riskplan --token_file=FILE)");
    EXPECT_THAT(answer.response, Not(HasSubstr("riskplan.v1.Planner")));
  }
  client::ConnectionOptions viewer;
  viewer.token_file = P("viewer.token");
  const ReflectionAnswer listed = AskReflection(Client(*server, viewer).channel());
  EXPECT_TRUE(listed.status.ok()) << listed.status.error_message();
  EXPECT_THAT(listed.response, HasSubstr("riskplan.v1.Planner"));
  EXPECT_THAT(listed.response, HasSubstr("grpc.health.v1.Health"));
  const ReflectionAnswer file =
      AskReflection(Client(*server, viewer).channel(), "riskplan.v1.Planner");
  EXPECT_TRUE(file.status.ok()) << file.status.error_message();
  EXPECT_THAT(file.response, HasSubstr("riskplan/v1/planner.proto"));
  EXPECT_THAT(file.response, HasSubstr("PlanTrajectory"));
  // A token the file does not list is refused as for any method.
  client::ConnectionOptions unknown;
  unknown.token_file = P("unknown.token");
  EXPECT_EQ(AskReflection(Client(*server, unknown).channel()).status.error_code(),
            grpc::StatusCode::UNAUTHENTICATED);
  // Without --token_file the plaintext loopback port is open to all, and
  // reflection with it.
  std::unique_ptr<ServerProcess> open = Start({});
  ASSERT_NE(open, nullptr);
  const ReflectionAnswer open_list = AskReflection(Client(*open, no_token).channel());
  EXPECT_TRUE(open_list.status.ok()) << open_list.status.error_message();
  EXPECT_THAT(open_list.response, HasSubstr("riskplan.v1.Planner"));
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

}  // namespace
}  // namespace riskplan::testing
