// ChannelTarget: the static list of replicas a `--server` may hold, resolved
// into one gRPC target, and what is passed to gRPC unchanged.
#include "client/channel_target.h"

#include <string>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace riskplan::client {
namespace {

using ::testing::HasSubstr;

TEST(ChannelTargetTest, OneAddressAndGrpcUrisPassUnchanged) {
  for (const char* target :
       {"127.0.0.1:50051", "localhost:50051", "riskplan-server:50051",
        "dns:///riskplan-server.default.svc:50051", "ipv4:10.0.0.1:1,10.0.0.2:2",
        "ipv6:[::1]:5,[::1]:6", "unix:/run/riskplan.sock", "[::1]:50051"}) {
    absl::StatusOr<std::string> got = ChannelTarget(target);
    ASSERT_TRUE(got.ok()) << target << ": " << got.status();
    EXPECT_EQ(*got, target);
  }
}

TEST(ChannelTargetTest, AStaticListBecomesOneListOfAddresses) {
  EXPECT_EQ(*ChannelTarget("127.0.0.1:50051,127.0.0.2:50052"),
            "ipv4:127.0.0.1:50051,127.0.0.2:50052");
  // Spaces around entries are allowed; a name is resolved (localhost has an
  // IPv4 address everywhere), and an address given twice is listed once.
  EXPECT_EQ(*ChannelTarget("localhost:7001, 127.0.0.1:7002,127.0.0.1:7002"),
            "ipv4:127.0.0.1:7001,127.0.0.1:7002");
  EXPECT_EQ(*ChannelTarget("[::1]:7001,[::1]:7002"), "ipv6:[::1]:7001,[::1]:7002");
}

TEST(ChannelTargetTest, ABadEntryIsNamedWithItsPlaceInTheList) {
  struct Case {
    std::string target;
    std::string says;
  };
  const Case cases[] = {
      {"127.0.0.1:1,,127.0.0.1:2", "entry 2 of the list is empty"},
      {"127.0.0.1:1,127.0.0.1", "entry 2 (\"127.0.0.1\"): expected HOST:PORT"},
      {"127.0.0.1:0,127.0.0.1:2", "entry 1 (\"127.0.0.1:0\"): expected HOST:PORT with a port in "
                                  "1..65535"},
      {"127.0.0.1:1,127.0.0.1:65536", "entry 2 (\"127.0.0.1:65536\")"},
      {"127.0.0.1:1,127.0.0.1:x", "entry 2 (\"127.0.0.1:x\")"},
      {"127.0.0.1:1,[::1:2", "entry 2 (\"[::1:2\"): an IPv6 address is written [ADDRESS]:PORT"},
      {"127.0.0.1:1,[::1]:2", "entry 2 (\"[::1]:2\") is IPv6 while the ones before it are IPv4"},
      {"127.0.0.1:1,no-such-replica.invalid:2", "entry 2 (\"no-such-replica.invalid:2\"): "},
  };
  for (const Case& c : cases) {
    absl::StatusOr<std::string> got = ChannelTarget(c.target);
    ASSERT_FALSE(got.ok()) << c.target << " gave " << *got;
    EXPECT_EQ(got.status().code(), absl::StatusCode::kInvalidArgument) << c.target;
    EXPECT_THAT(got.status().message(), HasSubstr(c.says)) << c.target;
    EXPECT_THAT(got.status().message(), HasSubstr(c.target)) << c.target;
  }
}

TEST(ChannelTargetTest, AListHoldsAtMostTheBoundOfEntries) {
  std::vector<std::string> entries;
  for (int i = 0; i < kMaxStaticTargets; ++i) entries.push_back(absl::StrCat("127.0.0.1:", 1000 + i));
  absl::StatusOr<std::string> at = ChannelTarget(absl::StrJoin(entries, ","));
  ASSERT_TRUE(at.ok()) << at.status();
  EXPECT_EQ(*at, absl::StrCat("ipv4:", absl::StrJoin(entries, ",")));
  entries.push_back("127.0.0.1:2000");
  absl::StatusOr<std::string> over = ChannelTarget(absl::StrJoin(entries, ","));
  ASSERT_FALSE(over.ok());
  EXPECT_THAT(over.status().message(), HasSubstr("a list of 65 servers; at most 64"));
}

}  // namespace
}  // namespace riskplan::client
