// Out of file descriptors at accept: the server keeps serving the calls and
// connections it has, says so in its log, and accepts again once descriptors
// are free. (gRPC 1.51's own listener stops accepting for good after one
// EMFILE; server/security/connection_acceptor.h is why this passes.)
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <memory>
#include <string>
#include <vector>

#include "absl/strings/match.h"
#include "absl/time/clock.h"
#include "gmock/gmock.h"
#include "grpcpp/grpcpp.h"
#include "gtest/gtest.h"
#include "tests/integration/requests.h"
#include "tests/integration/server_process.h"

namespace riskplan::testing {
namespace {

using ::testing::HasSubstr;

// A TCP connection to `address` that never says anything; -1 on failure.
int OpenSilentConnection(const std::string& address) {
  const size_t colon = address.rfind(':');
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(std::stoi(address.substr(colon + 1))));
  inet_pton(AF_INET, address.substr(0, colon).c_str(), &addr.sin_addr);
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd >= 0 && connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}

// Waits until the server's log holds `text` (it is polled: the log is a file).
bool WaitForLog(const ServerProcess& server, const std::string& text, absl::Duration timeout) {
  const absl::Time deadline = absl::Now() + timeout;
  while (!absl::StrContains(server.Stderr(), text)) {
    if (absl::Now() > deadline) return false;
    absl::SleepFor(absl::Milliseconds(20));
  }
  return true;
}

TEST(FdExhaustionTest, ServesOpenCallsAndAcceptsAgainOnceDescriptorsAreFree) {
  // 64 descriptors (an idle server holds about ten); one planning thread,
  // and room for a second plan to wait for it.
  auto started = ServerProcess::Start({"--plan_threads=1", "--max_running_plans=2"},
                                      absl::Seconds(60), /*max_open_files=*/64);
  ASSERT_TRUE(started.ok()) << started.status();
  std::unique_ptr<ServerProcess> server = *std::move(started);
  client::RiskplanClient client(server->Channel());

  // Plan A holds the planning thread until this test cancels it; plan B is
  // admitted and waits for the thread: both are in flight on the server.
  grpc::ClientContext a_context, b_context;
  client::SetTimeout(&a_context, absl::Seconds(300));
  client::SetTimeout(&b_context, absl::Seconds(300));
  auto plan_a = client.stub().PlanTrajectory(&a_context, SmallCityPlan(600000));
  v1::PlanUpdate update;
  ASSERT_TRUE(plan_a->Read(&update)) << plan_a->Finish().error_message();
  auto plan_b = client.stub().PlanTrajectory(&b_context, SmallCityPlan(0, 300));

  // Connections until accept fails: more than the server has descriptors.
  std::vector<int> flood;
  for (int i = 0; i < 100; ++i) {
    const int fd = OpenSilentConnection(server->address());
    ASSERT_GE(fd, 0) << "connection " << i;
    flood.push_back(fd);
  }
  // Whoever logs it (gRPC's own listener did too, before it stopped).
  ASSERT_TRUE(WaitForLog(*server, "Too many open files", absl::Seconds(60))) << server->Stderr();
  EXPECT_THAT(server->Stderr(), HasSubstr("\"event\":\"accept_failed\""));

  // Out of descriptors, the open connection still serves: a new call on it,
  // and plan B, which starts once A is cancelled and runs to its end.
  v1::EvaluateRiskResponse response;
  const grpc::Status eval = client.EvaluateRisk(SmallCityPolyline(), &response);
  EXPECT_TRUE(eval.ok()) << eval.error_message() << "\nserver log:\n" << server->Stderr();
  a_context.TryCancel();
  while (plan_a->Read(&update)) {
  }
  EXPECT_EQ(plan_a->Finish().error_code(), grpc::StatusCode::CANCELLED);
  std::vector<v1::PlanUpdate> b_updates;
  while (plan_b->Read(&update)) b_updates.push_back(update);
  const grpc::Status b_status = plan_b->Finish();
  EXPECT_TRUE(b_status.ok()) << b_status.error_message();
  ASSERT_FALSE(b_updates.empty());
  EXPECT_TRUE(b_updates.back().final());
  EXPECT_EQ(b_updates.back().end_reason(), v1::BUDGET_EXHAUSTED);
  EXPECT_EQ(b_updates.back().iterations(), 300);

  // Descriptors free again: new connections are served, every one of them.
  // (gRPC's own listener keeps a listening socket per poller, with
  // SO_REUSEPORT, and the kernel spreads connections over them: after EMFILE
  // the connections that land on a dead one wait for ever. Eight connections
  // all served say none is dead.)
  for (int fd : flood) close(fd);
  for (int k = 0; k < 8; ++k) {
    grpc::ChannelArguments own_connection;
    own_connection.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
    client::RiskplanClient newcomer(
        *client::MakeChannel(server->address(), server->connection(), own_connection));
    const grpc::Status ping = newcomer.Ping(absl::Seconds(60));
    EXPECT_TRUE(ping.ok()) << "new client " << k << ": " << ping.error_message();
  }
  EXPECT_TRUE(WaitForLog(*server, "\"event\":\"accept_resumed\"", absl::Seconds(60)))
      << server->Stderr();
}

}  // namespace
}  // namespace riskplan::testing
