// The server's structured log: what reaches stderr stays one JSON object per
// line, whatever a request holds.
#include "server/observability/rpc_log.h"

#include <string>

#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "riskplan/v1/planner.pb.h"

namespace riskplan::server {
namespace {

// A PlanRequest whose `map` (a proto3 string) is not UTF-8: Protobuf logs an
// error while parsing it (found by the request fuzz target, as a plain
// "[libprotobuf ERROR ...]" line in the middle of the JSON log).
std::string RequestWithInvalidUtf8() {
  std::string bytes = "\x0a\x03";  // field 1 (map), 3 bytes
  bytes += "\xff\xfe\xfd";
  return bytes;
}

TEST(RpcLogTest, ProtobufMessagesBecomeJsonEvents) {
  RouteProtobufLogs();
  testing::internal::CaptureStderr();
  v1::PlanRequest request;
  EXPECT_FALSE(request.ParseFromString(RequestWithInvalidUtf8()));
  const std::string logged = testing::internal::GetCapturedStderr();
  ASSERT_FALSE(logged.empty());
  ASSERT_EQ(logged.back(), '\n');
  ASSERT_EQ(logged.find('\n'), logged.size() - 1) << logged;  // one line
  const nlohmann::json line = nlohmann::json::parse(logged);
  EXPECT_EQ(line.at("event"), "protobuf");
  const std::string detail = line.at("detail").get<std::string>();
  EXPECT_EQ(detail.rfind("ERROR ", 0), 0u) << detail;
  EXPECT_NE(detail.find("riskplan.v1.PlanRequest.map"), std::string::npos) << detail;
  EXPECT_NE(detail.find("UTF-8"), std::string::npos) << detail;
}

TEST(RpcLogTest, EventsAreOneJsonObjectPerLine) {
  testing::internal::CaptureStderr();
  LogEvent("test", "a detail with \"quotes\", a newline\n and \xff bytes");
  const std::string logged = testing::internal::GetCapturedStderr();
  ASSERT_EQ(logged.find('\n'), logged.size() - 1) << logged;
  const nlohmann::json line = nlohmann::json::parse(logged);
  EXPECT_EQ(line.at("event"), "test");
}

}  // namespace
}  // namespace riskplan::server
