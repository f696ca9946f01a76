// Roles per method, the token file and the decisions of Authorizer, without
// gRPC's transport (server/security/auth.h).
#include "server/security/auth.h"

#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace riskplan::server {
namespace {

using ::testing::HasSubstr;

TEST(RequiredRoleTest, EveryMethodHasItsRoleAndHealthIsOpen) {
  EXPECT_EQ(RequiredRole("/grpc.health.v1.Health/Check"), std::nullopt);
  EXPECT_EQ(RequiredRole("/grpc.health.v1.Health/Watch"), std::nullopt);
  EXPECT_EQ(RequiredRole("ListMaps"), Role::kViewer);
  EXPECT_EQ(RequiredRole("/riskplan.v1.Planner/GetMapLayer"), Role::kViewer);
  EXPECT_EQ(RequiredRole("GetRiskLayer"), Role::kViewer);
  EXPECT_EQ(RequiredRole("EvaluateRisk"), Role::kViewer);
  EXPECT_EQ(RequiredRole("/riskplan.v1.Planner/PlanTrajectory"), Role::kPlanner);
  EXPECT_EQ(RequiredRole("/riskplan.v1.Planner/PlanFleet"), Role::kPlanner);
  EXPECT_EQ(RequiredRole("Ping"), Role::kOperator);
  EXPECT_EQ(RequiredRole("/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo"),
            Role::kViewer);
  // A method nobody gave a role yet is closed to all but operators.
  EXPECT_EQ(RequiredRole("/riskplan.v1.Planner/PlanSomethingNew"), Role::kOperator);
}

TEST(TokenHashTest, IsTheHexSha256OfTheToken) {
  // echo -n abc | sha256sum
  EXPECT_EQ(TokenHash("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

class TokenFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char name[] = "/tmp/riskplan-tokens-XXXXXX";
    const int fd = mkstemp(name);
    ASSERT_GE(fd, 0);
    close(fd);
    path_ = name;
  }
  void TearDown() override { unlink(path_.c_str()); }
  void Write(const std::string& text) {
    // A new file renamed over the old one, as an editor or a Secret does.
    const std::string next = path_ + ".next";
    std::ofstream(next) << text;
    ASSERT_EQ(std::rename(next.c_str(), path_.c_str()), 0);
  }
  std::string path_;
};

TEST_F(TokenFileTest, ParseErrorsNameTheFileAndTheLine) {
  Write("# comment\n\n" + TokenHash("a") + " alice viewer\nnot-a-hash bob planner\n");
  absl::StatusOr<std::shared_ptr<TokenStore>> store = TokenStore::Load(path_);
  ASSERT_FALSE(store.ok());
  EXPECT_THAT(std::string(store.status().message()),
              HasSubstr(absl::StrCat("--token_file=", path_, ": line 4: the first field must be")));
  Write(TokenHash("a") + " alice admin\n");
  store = TokenStore::Load(path_);
  ASSERT_FALSE(store.ok());
  EXPECT_THAT(std::string(store.status().message()),
              HasSubstr("line 1: role 'admin' is not viewer, planner or operator"));
  Write(TokenHash("a") + " alice viewer\n" + TokenHash("a") + " bob viewer\n");
  EXPECT_THAT(std::string(TokenStore::Load(path_).status().message()),
              HasSubstr("line 2: this token hash is listed twice"));
  EXPECT_THAT(std::string(TokenStore::Load("/nonexistent/tokens").status().message()),
              HasSubstr("--token_file=/nonexistent/tokens: cannot read it"));
}

TEST_F(TokenFileTest, ReloadsAChangedFileAndKeepsTheOldTableIfTheNewOneIsBroken) {
  Write(TokenHash("t1") + " alice viewer\n");
  absl::StatusOr<std::shared_ptr<TokenStore>> loaded = TokenStore::Load(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  TokenStore& store = **loaded;
  ASSERT_TRUE(store.Find("t1").has_value());
  EXPECT_EQ(store.Find("t1")->identity, "alice");
  EXPECT_FALSE(store.Find("t2").has_value());
  Write(TokenHash("t2") + " bob operator\n");
  // Looked at once a second at most.
  const absl::Time deadline = absl::Now() + absl::Seconds(30);
  while (!store.Find("t2").has_value() && absl::Now() < deadline) {
    absl::SleepFor(absl::Milliseconds(100));
  }
  ASSERT_TRUE(store.Find("t2").has_value());
  EXPECT_EQ(store.Find("t2")->role, Role::kOperator);
  EXPECT_FALSE(store.Find("t1").has_value());  // revoked by the rewrite
  Write("garbage\n");
  absl::SleepFor(absl::Milliseconds(1100));
  EXPECT_TRUE(store.Find("t2").has_value());  // the broken file is refused
}

TEST_F(TokenFileTest, AuthorizerDecidesUnauthenticatedOrPermissionDenied) {
  Write(TokenHash("view") + " alice viewer\n" + TokenHash("plan") + " paul planner\n");
  absl::StatusOr<std::shared_ptr<TokenStore>> store = TokenStore::Load(path_);
  ASSERT_TRUE(store.ok());
  const Authorizer authorizer(*store);
  Caller caller;
  grpc::Status s = authorizer.CheckToken(std::nullopt, "ListMaps", &caller);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  s = authorizer.CheckToken("Basic dmlldw==", "ListMaps", &caller);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(s.error_message(), "the authorization metadata is not 'Bearer TOKEN'");
  s = authorizer.CheckToken("Bearer nope", "ListMaps", &caller);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_THAT(s.error_message(), ::testing::Not(HasSubstr("nope")));
  s = authorizer.CheckToken("Bearer view", "EvaluateRisk", &caller);
  EXPECT_TRUE(s.ok());
  EXPECT_EQ(caller.identity, "alice");
  s = authorizer.CheckToken("Bearer view", "/riskplan.v1.Planner/PlanTrajectory", &caller);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::PERMISSION_DENIED);
  EXPECT_EQ(s.error_message(), "alice has role viewer; PlanTrajectory needs role planner or above");
  EXPECT_TRUE(authorizer.CheckToken("Bearer plan", "PlanTrajectory", &caller).ok());
  EXPECT_EQ(authorizer.CheckToken("Bearer plan", "Ping", &caller).error_code(),
            grpc::StatusCode::PERMISSION_DENIED);
  // Health needs no token.
  EXPECT_TRUE(authorizer.CheckToken(std::nullopt, "/grpc.health.v1.Health/Check", &caller).ok());
  // Without a token file every call passes.
  EXPECT_TRUE(Authorizer(nullptr).CheckToken(std::nullopt, "Ping", &caller).ok());
}

TEST(IdentityLabelsTest, BoundsTheNumberOfDistinctLabels) {
  IdentityLabels labels;
  EXPECT_EQ(labels.Label(""), "anonymous");
  for (size_t i = 0; i < kMaxIdentityLabels; ++i) {
    EXPECT_EQ(labels.Label(absl::StrCat("id-", i)), absl::StrCat("id-", i));
  }
  EXPECT_EQ(labels.Label("one-too-many"), "other");
  EXPECT_EQ(labels.Label("id-3"), "id-3");  // known ones keep theirs
}

}  // namespace
}  // namespace riskplan::server
