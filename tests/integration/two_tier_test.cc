// EvaluateRisk's two-tier feasibility option through the real server and the
// `riskplan eval --two_tier` command: which tier finds a collision, a feasible
// trajectory, and bad options refused with INVALID_ARGUMENT naming the field.
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/integration/requests.h"
#include "tests/integration/server_process.h"
#include "tests/integration/shared_server_test.h"

namespace riskplan::testing {
namespace {

using ::testing::HasSubstr;

class TwoTierTest : public SharedServerTest<TwoTierTest> {
 protected:
  // A polyline on the small demo-city with the two-tier check enabled.
  static v1::EvaluateRiskRequest Request(const std::string& points) {
    v1::EvaluateRiskRequest r;
    r.set_map("demo-city");
    *r.mutable_polyline() = *client::ParsePolyline(points);
    r.mutable_two_tier()->set_enabled(true);
    return r;
  }

  v1::EvaluateRiskResponse Evaluate(const v1::EvaluateRiskRequest& request) {
    v1::EvaluateRiskResponse response;
    grpc::Status status = client_->EvaluateRisk(request, &response);
    EXPECT_TRUE(status.ok()) << status.error_message();
    return response;
  }
};

// Four pieces at 250 m, then (optionally) a dive into the terrain.
constexpr char kHigh[] = "300,375,250; 600,500,250; 900,700,250; 1200,900,250";

TEST_F(TwoTierTest, NotRequestedNotAnswered) {
  v1::EvaluateRiskRequest r = SmallCityPolyline();
  EXPECT_FALSE(Evaluate(r).has_two_tier());
}

TEST_F(TwoTierTest, FeasibleTrajectory) {
  v1::EvaluateRiskResponse r = Evaluate(Request(kHigh));
  EXPECT_TRUE(r.admissible());
  ASSERT_TRUE(r.has_two_tier());
  EXPECT_TRUE(r.two_tier().feasible()) << r.two_tier().DebugString();
  EXPECT_EQ(r.two_tier().tier(), v1::FEASIBILITY_TIER_UNSPECIFIED);
  EXPECT_EQ(r.two_tier().segment(), -1);
  EXPECT_GT(r.two_tier().cells_checked(), 100);
}

TEST_F(TwoTierTest, DiveFarFromTheStartIsFoundByTheCoarseTier) {
  v1::EvaluateRiskResponse r = Evaluate(Request(std::string(kHigh) + "; 1500,1100,-50"));
  EXPECT_FALSE(r.admissible());
  ASSERT_TRUE(r.has_two_tier());
  const v1::TwoTierResult& t = r.two_tier();
  EXPECT_FALSE(t.feasible());
  EXPECT_EQ(t.tier(), v1::COARSE);
  EXPECT_EQ(t.segment(), 3);  // the dive: pieces 0 and 1 are detailed
  EXPECT_THAT(t.kind(), ::testing::AnyOf(v1::TERRAIN_COLLISION, v1::BELOW_SAFE_ALTITUDE));
  // A block of 16 x 16 cells of 5 m: 80 m.
  EXPECT_EQ(t.cell_i(), static_cast<int>(t.position().x() / 80.0));
  EXPECT_EQ(t.cell_j(), static_cast<int>(t.position().y() / 80.0));
  EXPECT_GE(t.position().x(), 1200.0);

  // With every piece detailed, the detailed tier finds it, in a map cell.
  v1::EvaluateRiskRequest all_detailed = Request(std::string(kHigh) + "; 1500,1100,-50");
  all_detailed.mutable_two_tier()->set_detailed_segments(10);
  const v1::TwoTierResult d = Evaluate(all_detailed).two_tier();
  EXPECT_EQ(d.tier(), v1::DETAILED);
  EXPECT_EQ(d.segment(), 3);
  EXPECT_EQ(d.cell_i(), static_cast<int>(d.position().x() / 5.0));
}

TEST_F(TwoTierTest, DiveNearTheStartIsFoundByTheDetailedTier) {
  v1::EvaluateRiskResponse r = Evaluate(Request("300,375,250; 600,500,-50; 900,700,250"));
  EXPECT_FALSE(r.admissible());
  const v1::TwoTierResult& t = r.two_tier();
  EXPECT_FALSE(t.feasible());
  EXPECT_EQ(t.tier(), v1::DETAILED);
  EXPECT_EQ(t.segment(), 0);
  EXPECT_THAT(t.kind(), ::testing::AnyOf(v1::TERRAIN_COLLISION, v1::BELOW_SAFE_ALTITUDE));
  EXPECT_EQ(t.cell_i(), static_cast<int>(t.position().x() / 5.0));
  EXPECT_EQ(t.cell_j(), static_cast<int>(t.position().y() / 5.0));

  // Seed 001's rule: only the terrain counts, so the collision is deeper.
  v1::EvaluateRiskRequest terrain = Request("300,375,250; 600,500,-50; 900,700,250");
  terrain.mutable_two_tier()->set_rule(v1::TERRAIN_ONLY);
  const v1::TwoTierResult u = Evaluate(terrain).two_tier();
  EXPECT_EQ(u.tier(), v1::DETAILED);
  EXPECT_EQ(u.kind(), v1::TERRAIN_COLLISION);
  EXPECT_LT(u.position().z(), t.position().z());
}

TEST_F(TwoTierTest, BadOptionsAreInvalidArgumentNamingTheField) {
  struct Case {
    void (*set)(v1::TwoTierOptions*);
    const char* message;
  };
  const Case cases[] = {
      {[](v1::TwoTierOptions* o) { o->set_detailed_segments(-3); },
       "two_tier.detailed_segments has value -3"},
      {[](v1::TwoTierOptions* o) { o->set_block_cells(0); }, "block_cells is 0"},
      {[](v1::TwoTierOptions* o) { o->set_block_cells(2000); }, "block_cells is 2000"},
      {[](v1::TwoTierOptions* o) { o->set_rule(static_cast<v1::CollisionRule>(9)); },
       "two_tier.rule has value 9"},
  };
  for (const Case& c : cases) {
    v1::EvaluateRiskRequest r = Request(kHigh);
    c.set(r.mutable_two_tier());
    v1::EvaluateRiskResponse response;
    grpc::Status status = client_->EvaluateRisk(r, &response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << c.message;
    EXPECT_THAT(status.error_message(), HasSubstr(c.message));
  }
}

TEST_F(TwoTierTest, CliPrintsTheTier) {
  const std::string cli = std::string(RISKPLAN_BIN_DIR) +
                          "/riskplan " + server_->CliServerFlags() + " eval --polyline='" +
                          kHigh + "; 1500,1100,-50' --two_tier";
  CommandResult r = RunCommand(cli + " 2>&1");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("two-tier check: NOT feasible: COARSE tier"));
  EXPECT_THAT(r.output, HasSubstr("in piece 3"));
  r = RunCommand(cli + " --two_tier_detailed_segments=10 --two_tier_rule=terrain_only 2>&1");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("NOT feasible: DETAILED tier, TERRAIN_COLLISION in piece 3"));
  r = RunCommand(std::string(RISKPLAN_BIN_DIR) + "/riskplan " + server_->CliServerFlags() +
                 " eval --polyline='" + kHigh + "' --two_tier --two_tier_bresenham 2>&1");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("two-tier check: feasible"));
  r = RunCommand(cli + " --two_tier_block_cells=0 2>&1");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_THAT(r.output, HasSubstr("INVALID_ARGUMENT"));
  EXPECT_THAT(r.output, HasSubstr("block_cells is 0"));
  r = RunCommand(cli + " --two_tier_rule=sideways 2>&1");
  EXPECT_EQ(r.exit_code, 2) << r.output;
}

}  // namespace
}  // namespace riskplan::testing
