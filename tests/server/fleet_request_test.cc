// PlanFleet's request: the fleet's own bounds refuse the whole request, a
// mission's errors are its own with its path, and which missions share a tree.
#include "server/fleet/fleet_request.h"

#include "absl/strings/str_format.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/core/test_maps.h"

namespace riskplan::server {
namespace {

using ::testing::HasSubstr;

class FleetRequestTest : public ::testing::Test {
 protected:
  FleetRequestTest() {
    // 2 km x 2 km, flat terrain at 100 m AMSL.
    auto registry = MapRegistry::FromMaps(
        {testing_maps::UniformMap(200, 200, 10.0, 0.001f, 2.0f, 100.0f, {}, "test-city")});
    EXPECT_TRUE(registry.ok()) << registry.status();
    registry_ = *std::move(registry);
    limits_.max_fleet_missions = 4;
  }

  // A valid RISK_RRT_STAR mission from (x, 200) to the common goal.
  static v1::FleetMission Mission(const std::string& id, double x) {
    v1::FleetMission m;
    m.set_id(id);
    v1::PlanRequest& r = *m.mutable_request();
    r.set_map("test-city");
    r.mutable_start()->set_x(x);
    r.mutable_start()->set_y(200);
    r.mutable_start()->set_z(180);
    r.mutable_goal()->set_x(1800);
    r.mutable_goal()->set_y(1800);
    r.mutable_goal()->set_z(180);
    r.mutable_budget()->set_iterations(100);
    r.set_seed(3);
    return m;
  }

  absl::StatusOr<FleetSpec> Validate(const v1::FleetRequest& r) {
    return ValidateFleetRequest(r, *registry_, limits_);
  }

  std::unique_ptr<MapRegistry> registry_;
  RequestLimits limits_;
};

TEST_F(FleetRequestTest, TheFleetsOwnBoundsRefuseTheWholeRequest) {
  v1::FleetRequest r;
  EXPECT_EQ(Validate(r).status().message(),
            "missions has 0 missions; it must have 1 to 4 (--max_fleet_missions)");
  for (int i = 0; i < 5; ++i) *r.add_missions() = Mission(absl::StrFormat("m%d", i), 200);
  EXPECT_EQ(Validate(r).status().message(),
            "missions has 5 missions; it must have 1 to 4 (--max_fleet_missions)");
  r.mutable_missions()->RemoveLast();
  r.mutable_missions(2)->set_id("m1");
  EXPECT_THAT(Validate(r).status().message(),
              HasSubstr("missions[2].id 'm1' is the id of an earlier mission"));
  r.mutable_missions(2)->set_id("");
  EXPECT_THAT(Validate(r).status().message(), HasSubstr("missions[2].id has 0 bytes"));
  r.mutable_missions(2)->set_id("m2");
  r.mutable_missions(3)->set_priority(1001);
  EXPECT_EQ(Validate(r).status().message(),
            "missions[3].priority has value 1001; it must be in [0, 1000]");
  r.mutable_missions(3)->set_priority(1000);
  r.set_tenant(std::string(65, 't'));
  EXPECT_THAT(Validate(r).status().message(), HasSubstr("tenant has 65 bytes"));
  r.set_tenant("ground-1");
  EXPECT_TRUE(Validate(r).ok());
}

TEST_F(FleetRequestTest, AMissionsErrorIsItsOwnWithItsPath) {
  v1::FleetRequest r;
  *r.add_missions() = Mission("good", 200);
  *r.add_missions() = Mission("outside", 200);
  r.mutable_missions(1)->mutable_request()->mutable_start()->set_x(5000);
  *r.add_missions() = Mission("nomap", 200);
  r.mutable_missions(2)->mutable_request()->set_map("atlantis");
  absl::StatusOr<FleetSpec> spec = Validate(r);
  ASSERT_TRUE(spec.ok()) << spec.status();
  EXPECT_TRUE(spec->missions[0].plan.ok());
  EXPECT_EQ(spec->missions[1].plan.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(spec->missions[1].plan.status().message(),
              HasSubstr("missions[1].request.start (x, y) = (5000, 200) is outside map"));
  EXPECT_EQ(spec->missions[2].plan.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(spec->missions[2].plan.status().message(),
              HasSubstr("missions[2].request.map 'atlantis' is not served"));
  // The invalid missions are in no group.
  std::vector<MissionGroup> groups = GroupMissions(*spec);
  ASSERT_EQ(groups.size(), 1u);
  EXPECT_EQ(groups[0].missions, std::vector<size_t>{0});
  EXPECT_FALSE(groups[0].shared);
}

TEST_F(FleetRequestTest, MissionsShareATreeOnlyWhenEverythingButStartAndBudgetIsEqual) {
  v1::FleetRequest r;
  for (int i = 0; i < 4; ++i) *r.add_missions() = Mission(absl::StrFormat("m%d", i), 200 + 100 * i);
  r.mutable_missions(1)->set_priority(7);
  r.mutable_missions(1)->mutable_request()->mutable_budget()->set_iterations(500);  // own budget
  r.mutable_missions(2)->mutable_request()->set_seed(4);                            // another seed
  r.mutable_missions(3)->mutable_request()->set_algorithm(v1::RRT);                 // alone
  absl::StatusOr<FleetSpec> spec = Validate(r);
  ASSERT_TRUE(spec.ok()) << spec.status();
  std::vector<MissionGroup> groups = GroupMissions(*spec);
  ASSERT_EQ(groups.size(), 3u);
  EXPECT_EQ(groups[0].missions, (std::vector<size_t>{0, 1}));
  EXPECT_TRUE(groups[0].shared);
  EXPECT_EQ(groups[0].priority, 7);
  EXPECT_EQ(groups[1].missions, std::vector<size_t>{2});
  EXPECT_EQ(groups[2].missions, std::vector<size_t>{3});
  EXPECT_FALSE(groups[2].shared);

  // Other model parameters, another goal heading: other trees.
  r.mutable_missions(2)->mutable_request()->set_seed(3);
  r.mutable_missions(2)->mutable_request()->mutable_model_params()->set_mass_kg(12);
  r.mutable_missions(3)->mutable_request()->set_algorithm(v1::RISK_RRT_STAR);
  r.mutable_missions(3)->mutable_request()->mutable_goal()->set_theta(1.0);
  spec = Validate(r);
  ASSERT_TRUE(spec.ok()) << spec.status();
  groups = GroupMissions(*spec);
  ASSERT_EQ(groups.size(), 3u);
  EXPECT_EQ(groups[0].missions, (std::vector<size_t>{0, 1}));
}

// Limits are per mission: a mission with limits is validated with its own
// (a bad one named with the mission's path) and planned alone, since the
// shared tree's planner does not apply them.
TEST_F(FleetRequestTest, MissionsWithLimitsArePlannedAloneWithTheirOwnLimits) {
  v1::FleetRequest r;
  for (int i = 0; i < 4; ++i) *r.add_missions() = Mission(absl::StrFormat("m%d", i), 200 + 100 * i);
  r.mutable_missions(1)->mutable_request()->mutable_limits()->set_max_flight_time_s(600);
  r.mutable_missions(2)->mutable_request()->mutable_limits()->set_objective(v1::MIN_TIME);
  r.mutable_missions(3)->mutable_request()->mutable_limits()->set_max_risk(-1);
  absl::StatusOr<FleetSpec> spec = Validate(r);
  ASSERT_TRUE(spec.ok()) << spec.status();
  ASSERT_TRUE(spec->missions[1].plan.ok());
  EXPECT_EQ(spec->missions[1].plan->options.limits.max_flight_time_s, 600.0);
  EXPECT_EQ(spec->missions[2].plan->options.limits.objective, PlanObjective::kMinTime);
  EXPECT_EQ(spec->missions[0].plan->options.limits.max_flight_time_s, 0.0);
  EXPECT_THAT(spec->missions[3].plan.status().message(),
              HasSubstr("missions[3].request.limits.max_risk is -1"));
  std::vector<MissionGroup> groups = GroupMissions(*spec);
  ASSERT_EQ(groups.size(), 3u);
  EXPECT_EQ(groups[0].missions, std::vector<size_t>{0});
  EXPECT_EQ(groups[1].missions, std::vector<size_t>{1});
  EXPECT_EQ(groups[2].missions, std::vector<size_t>{2});
}

TEST(MissionErrorTest, FieldErrorsGetTheRequestPathOthersTheMission) {
  EXPECT_EQ(MissionError(3, absl::InvalidArgumentError("start.z has value nan")).message(),
            "missions[3].request.start.z has value nan");
  EXPECT_EQ(MissionError(2, absl::UnavailableError("the board went away")).message(),
            "missions[2]: the board went away");
  EXPECT_TRUE(MissionError(1, absl::OkStatus()).ok());
}

}  // namespace
}  // namespace riskplan::server
