// net/ on its own (it links nothing else of the project): host:port parsing,
// the loopback rule for plaintext, a TCP round trip on 127.0.0.1 with its
// deadlines, and the TLS file checks' messages. TLS handshakes, rotation and
// revocation are tested on the shim link (tests/accel/shim_tls_test.cc),
// which needs a test PKI.
#include "net/net.h"

#include <openssl/err.h>

#include <string>

#include "absl/time/clock.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "net/tls_files.h"

namespace riskplan::net {
namespace {

using ::testing::HasSubstr;

TEST(SplitHostPortTest, SplitsV4V6AndEmptyHost) {
  std::string host;
  int port = -1;
  ASSERT_TRUE(SplitHostPort("127.0.0.1:7070", &host, &port).ok());
  EXPECT_EQ(host, "127.0.0.1");
  EXPECT_EQ(port, 7070);
  ASSERT_TRUE(SplitHostPort("[::1]:0", &host, &port).ok());
  EXPECT_EQ(host, "::1");
  EXPECT_EQ(port, 0);
  ASSERT_TRUE(SplitHostPort(":50051", &host, &port).ok());
  EXPECT_EQ(host, "");
  EXPECT_EQ(port, 50051);
}

TEST(SplitHostPortTest, RefusesMalformed) {
  std::string host;
  int port = 0;
  for (const char* bad : {"localhost", "host:", "host:x", "host:-1", "host:65536"}) {
    const absl::Status s = SplitHostPort(bad, &host, &port);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << bad;
    EXPECT_THAT(std::string(s.message()), HasSubstr(bad));
  }
}

TEST(IsLoopbackHostTest, OnlyLoopbackAddressesAndLocalhost) {
  for (const char* host : {"127.0.0.1", "127.8.9.10", "::1", "[::1]", "localhost"}) {
    EXPECT_TRUE(IsLoopbackHost(host)) << host;
  }
  for (const char* host : {"0.0.0.0", "10.0.0.1", "128.0.0.1", "::", "[::]", "", "board-1"}) {
    EXPECT_FALSE(IsLoopbackHost(host)) << host;
  }
}

// A listener on 127.0.0.1 and one connection to it: both ends.
struct Pair {
  Socket listener, client, server;
};

Pair Connected() {
  Pair p;
  std::string bound;
  absl::StatusOr<Socket> listener = ListenTcp("127.0.0.1:0", &bound);
  EXPECT_TRUE(listener.ok()) << listener.status();
  if (!listener.ok()) return p;
  EXPECT_THAT(bound, HasSubstr("127.0.0.1:"));
  absl::StatusOr<Socket> client = ConnectTcp(bound, absl::Now() + absl::Seconds(10));
  EXPECT_TRUE(client.ok()) << client.status();
  absl::StatusOr<Socket> server = Accept(*listener, absl::Now() + absl::Seconds(10));
  EXPECT_TRUE(server.ok()) << server.status();
  p.listener = *std::move(listener);
  if (client.ok()) p.client = *std::move(client);
  if (server.ok()) p.server = *std::move(server);
  return p;
}

TEST(SocketTest, RoundTripsOnLoopback) {
  Pair p = Connected();
  ASSERT_TRUE(p.client.valid() && p.server.valid());
  const absl::Time deadline = absl::Now() + absl::Seconds(10);
  ASSERT_TRUE(SendAll(p.client, "hello, shim", deadline).ok());
  std::string got(11, '\0');
  ASSERT_TRUE(RecvAll(p.server, got.data(), got.size(), deadline).ok());
  EXPECT_EQ(got, "hello, shim");
}

TEST(SocketTest, DeadlinesAndClosedPeers) {
  Pair p = Connected();
  ASSERT_TRUE(p.client.valid() && p.server.valid());
  char byte = 0;
  // Nothing sent: the read waits until its deadline, then gives up.
  EXPECT_EQ(RecvAll(p.server, &byte, 1, absl::Now() + absl::Milliseconds(50)).code(),
            absl::StatusCode::kDeadlineExceeded);
  // No second connection: Accept gives up too.
  EXPECT_EQ(Accept(p.listener, absl::Now() + absl::Milliseconds(50)).status().code(),
            absl::StatusCode::kDeadlineExceeded);
  // The peer closed: Unavailable, at once rather than at the deadline.
  p.client.Close();
  EXPECT_EQ(RecvAll(p.server, &byte, 1, absl::Now() + absl::Seconds(10)).code(),
            absl::StatusCode::kUnavailable);
}

TEST(SocketTest, MovesOwnership) {
  Pair p = Connected();
  ASSERT_TRUE(p.client.valid());
  const int fd = p.client.fd();
  Socket moved = std::move(p.client);
  EXPECT_EQ(moved.fd(), fd);
  EXPECT_FALSE(p.client.valid());
  EXPECT_EQ(moved.ssl(), nullptr);
}

TEST(TlsFilesTest, MessagesNameTheFlagAndFile) {
  const FlagFile missing{"tls_key", "/nonexistent/riskplan/tls.key"};
  const absl::StatusOr<std::string> read = ReadFlagFile(missing);
  EXPECT_EQ(read.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(std::string(read.status().message()),
              HasSubstr("--tls_key=/nonexistent/riskplan/tls.key"));
  const absl::Status pair = CheckCertificateAndKey({"tls_cert", "/nonexistent/cert.pem"}, missing);
  EXPECT_THAT(std::string(pair.message()), HasSubstr("--tls_key="));
  EXPECT_THAT(std::string(CheckCaBundle({"tls_client_ca", "/nonexistent/ca.pem"}).message()),
              HasSubstr("--tls_client_ca=/nonexistent/ca.pem"));
  EXPECT_EQ(CertificateSubject("not a certificate"), "");
}

TEST(TlsFilesTest, OpenSslErrorsEmptiesTheQueue) {
  ERR_clear_error();
  EXPECT_EQ(OpenSslErrors("none"), "none");
  ERR_raise(ERR_LIB_SSL, ERR_R_MALLOC_FAILURE);
  EXPECT_NE(OpenSslErrors("none"), "none");
  EXPECT_EQ(OpenSslErrors("none"), "none");
}

}  // namespace
}  // namespace riskplan::net
