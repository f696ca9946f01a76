#include "server/api/status_util.h"

#include <new>
#include <stdexcept>

#include "gtest/gtest.h"

namespace riskplan::server {
namespace {

TEST(StatusUtilTest, KeepsCodeAndMessage) {
  struct Case {
    absl::Status in;
    grpc::StatusCode code;
  };
  const Case cases[] = {
      {absl::InvalidArgumentError("start.z has value nan"), grpc::StatusCode::INVALID_ARGUMENT},
      {absl::NotFoundError("map 'x' is not served"), grpc::StatusCode::NOT_FOUND},
      {absl::ResourceExhaustedError("full"), grpc::StatusCode::RESOURCE_EXHAUSTED},
      {absl::FailedPreconditionError("fp"), grpc::StatusCode::FAILED_PRECONDITION},
      {absl::UnavailableError("draining"), grpc::StatusCode::UNAVAILABLE},
      {absl::InternalError("bug"), grpc::StatusCode::INTERNAL},
      {absl::DeadlineExceededError("late"), grpc::StatusCode::DEADLINE_EXCEEDED},
      {absl::CancelledError("gone"), grpc::StatusCode::CANCELLED},
      {absl::UnauthenticatedError("who"), grpc::StatusCode::UNAUTHENTICATED},
  };
  for (const Case& c : cases) {
    grpc::Status out = ToGrpcStatus(c.in);
    EXPECT_EQ(out.error_code(), c.code) << c.in;
    EXPECT_EQ(out.error_message(), c.in.message());
  }
}

TEST(StatusUtilTest, OkIsOk) { EXPECT_TRUE(ToGrpcStatus(absl::OkStatus()).ok()); }

TEST(StatusUtilTest, UnknownCodeBecomesUnknown) {
  grpc::Status out = ToGrpcStatus(absl::Status(static_cast<absl::StatusCode>(42), "odd"));
  EXPECT_EQ(out.error_code(), grpc::StatusCode::UNKNOWN);
  EXPECT_EQ(out.error_message(), "odd");
}

TEST(StatusUtilTest, CodeNames) {
  EXPECT_EQ(GrpcCodeName(grpc::StatusCode::OK), "OK");
  EXPECT_EQ(GrpcCodeName(grpc::StatusCode::RESOURCE_EXHAUSTED), "RESOURCE_EXHAUSTED");
  EXPECT_EQ(GrpcCodeName(grpc::StatusCode::DEADLINE_EXCEEDED), "DEADLINE_EXCEEDED");
  EXPECT_EQ(GrpcCodeName(grpc::StatusCode::UNAVAILABLE), "UNAVAILABLE");
}

// No exception leaves a request's thread: an allocation failure becomes
// RESOURCE_EXHAUSTED (the server ran out of memory), anything else INTERNAL.
TEST(StatusUtilTest, ExceptionsBecomeStatuses) {
  const absl::Status oom = StatusFromException(std::bad_alloc(), "EvaluateRisk");
  EXPECT_EQ(oom.code(), absl::StatusCode::kResourceExhausted);
  EXPECT_EQ(oom.message(),
            "EvaluateRisk: riskplan-server ran out of memory (std::bad_alloc); retry later or on "
            "another replica");
  const absl::Status other = StatusFromException(std::runtime_error("boom"), "PlanTrajectory");
  EXPECT_EQ(other.code(), absl::StatusCode::kInternal);
  EXPECT_EQ(other.message(), "PlanTrajectory: unexpected exception: boom");
}

}  // namespace
}  // namespace riskplan::server
