// Every bad input gets its status code and a message naming the field and
// the value, through the real server; and a bad request never disturbs good
// ones running at the same time.
#include <atomic>
#include <limits>
#include <thread>

#include "absl/time/clock.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/integration/requests.h"
#include "tests/integration/server_process.h"
#include "tests/integration/shared_server_test.h"

namespace riskplan::testing {
namespace {

using ::testing::HasSubstr;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

class ValidationTest : public SharedServerTest<ValidationTest> {
 public:
  static std::vector<std::string> ServerFlags() {
    return {"--max_waypoints=50", "--max_request_bytes=65536"};
  }

 protected:
  void ExpectPlanError(const v1::PlanRequest& request, grpc::StatusCode code,
                       const std::string& message_part) {
    PlanOutcome plan = RunPlan(*client_, request, absl::Seconds(30));
    EXPECT_EQ(plan.status.error_code(), code) << plan.status.error_message();
    EXPECT_THAT(plan.status.error_message(), HasSubstr(message_part));
    EXPECT_TRUE(plan.updates.empty());
  }

  void ExpectEvalError(const v1::EvaluateRiskRequest& request, grpc::StatusCode code,
                       const std::string& message_part) {
    v1::EvaluateRiskResponse response;
    grpc::Status status = client_->EvaluateRisk(request, &response);
    EXPECT_EQ(status.error_code(), code) << status.error_message();
    EXPECT_THAT(status.error_message(), HasSubstr(message_part));
  }
};

TEST_F(ValidationTest, UnknownMapIsNotFound) {
  v1::PlanRequest plan = SmallCityPlan(300);
  plan.set_map("gotham");
  ExpectPlanError(plan, grpc::StatusCode::NOT_FOUND,
                  "map 'gotham' is not served; served maps: demo-city");
  v1::EvaluateRiskRequest eval = SmallCityPolyline();
  eval.set_map("gotham");
  ExpectEvalError(eval, grpc::StatusCode::NOT_FOUND, "map 'gotham' is not served");
}

TEST_F(ValidationTest, NonFiniteNumbers) {
  v1::PlanRequest plan = SmallCityPlan(300);
  plan.mutable_start()->set_x(kNaN);
  ExpectPlanError(plan, grpc::StatusCode::INVALID_ARGUMENT, "start.x has value nan");
  plan = SmallCityPlan(300);
  plan.mutable_goal()->set_z(std::numeric_limits<double>::infinity());
  ExpectPlanError(plan, grpc::StatusCode::INVALID_ARGUMENT, "goal.z has value inf");
  v1::EvaluateRiskRequest eval = SmallCityPolyline();
  eval.mutable_polyline()->mutable_points(2)->set_z(-kNaN);
  ExpectEvalError(eval, grpc::StatusCode::INVALID_ARGUMENT, "polyline.points[2].z has value");
}

TEST_F(ValidationTest, PosesOutsideTheMap) {
  v1::PlanRequest plan = SmallCityPlan(300);
  plan.mutable_goal()->set_x(2100);
  ExpectPlanError(plan, grpc::StatusCode::INVALID_ARGUMENT,
                  "goal (x, y) = (2100, 1625) is outside map 'demo-city'");
}

TEST_F(ValidationTest, InadmissibleStartOrGoal) {
  v1::PlanRequest plan = SmallCityPlan(300);
  plan.mutable_start()->set_z(120);  // below the flight band over ~105+ m terrain
  ExpectPlanError(plan, grpc::StatusCode::INVALID_ARGUMENT, "start pose (300.0, 375.0, 120.0)");
  ExpectPlanError(plan, grpc::StatusCode::INVALID_ARGUMENT, "is not admissible");
  plan = SmallCityPlan(300);
  plan.mutable_goal()->set_z(1000);
  ExpectPlanError(plan, grpc::StatusCode::INVALID_ARGUMENT, "ABOVE_MAX_ALTITUDE");
}

TEST_F(ValidationTest, InadmissibleEndpointWithOverriddenParamsIsCheckedToo) {
  // The model for these parameters is not cached: the check runs on the plan
  // pool after the model is built, with the same answer.
  v1::PlanRequest plan = SmallCityPlan(300);
  plan.mutable_model_params()->set_max_agl_m(40);
  ExpectPlanError(plan, grpc::StatusCode::INVALID_ARGUMENT, "is not admissible");
}

TEST_F(ValidationTest, UnknownAlgorithm) {
  v1::PlanRequest plan = SmallCityPlan(300);
  plan.set_algorithm(static_cast<v1::Algorithm>(9));
  ExpectPlanError(plan, grpc::StatusCode::INVALID_ARGUMENT,
                  "algorithm has value 9, which this server does not offer");
}

TEST_F(ValidationTest, BadObstacles) {
  v1::PlanRequest plan = SmallCityPlan(300);
  plan.add_obstacle_points()->set_x(kNaN);
  ExpectPlanError(plan, grpc::StatusCode::INVALID_ARGUMENT, "obstacle_points[0].x has value nan");
  plan = SmallCityPlan(300);
  v1::DynamicObstacle* o = plan.add_dynamic_obstacles();
  o->set_x0_m(500);
  o->set_x1_m(400);
  o->set_y1_m(100);
  ExpectPlanError(plan, grpc::StatusCode::INVALID_ARGUMENT,
                  "dynamic_obstacles[0] is at_iteration 0, [500, 400] x [0, 100]");
}

TEST_F(ValidationTest, BudgetsAndIntervalsOutOfRange) {
  v1::PlanRequest plan = SmallCityPlan(-5);
  ExpectPlanError(plan, grpc::StatusCode::INVALID_ARGUMENT, "budget.time_ms has value -5");
  plan = SmallCityPlan(700000);
  ExpectPlanError(plan, grpc::StatusCode::INVALID_ARGUMENT,
                  "budget.time_ms has value 700000; it must be in [0, 600000]");
  plan = SmallCityPlan(300, -1);
  ExpectPlanError(plan, grpc::StatusCode::INVALID_ARGUMENT, "budget.iterations has value -1");
  plan = SmallCityPlan(300);
  plan.set_min_update_interval_ms(120000);
  ExpectPlanError(plan, grpc::StatusCode::INVALID_ARGUMENT,
                  "min_update_interval_ms has value 120000");
}

TEST_F(ValidationTest, ParametersOutOfRange) {
  v1::PlanRequest plan = SmallCityPlan(300);
  plan.mutable_model_params()->set_mass_kg(0);
  ExpectPlanError(plan, grpc::StatusCode::INVALID_ARGUMENT,
                  "model_params: parameter 'mass_kg' has value 0");
  plan = SmallCityPlan(300);
  (*plan.mutable_planner_params())["warp_factor"] = 9;
  ExpectPlanError(plan, grpc::StatusCode::INVALID_ARGUMENT,
                  "planner_params: unknown parameter 'warp_factor' for RISK_RRT_STAR");
  plan = SmallCityPlan(300);
  (*plan.mutable_planner_params())["goal_bias"] = kNaN;
  ExpectPlanError(plan, grpc::StatusCode::INVALID_ARGUMENT,
                  "planner_params['goal_bias'] has value nan");
  v1::EvaluateRiskRequest eval = SmallCityPolyline();
  eval.mutable_model_params()->set_sample_step_m(-1);
  ExpectEvalError(eval, grpc::StatusCode::INVALID_ARGUMENT,
                  "model_params: parameter 'sample_step_m' has value -1");
}

TEST_F(ValidationTest, TooManyWaypoints) {
  v1::EvaluateRiskRequest eval;
  eval.set_map("demo-city");
  for (int i = 0; i < 51; ++i) {
    v1::Pose* pose = eval.mutable_waypoints()->add_poses();
    pose->set_x(300 + 20 * i);
    pose->set_y(400);
    pose->set_z(240);
  }
  ExpectEvalError(eval, grpc::StatusCode::INVALID_ARGUMENT,
                  "waypoints.poses has 51 poses; it must have 2 to 50");
}

TEST_F(ValidationTest, OversizedMessageIsRefusedByTheTransport) {
  v1::EvaluateRiskRequest eval = SmallCityPolyline();
  eval.set_map(std::string(70000, 'x'));  // > --max_request_bytes=65536
  v1::EvaluateRiskResponse response;
  grpc::Status status = client_->EvaluateRisk(eval, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(status.error_message(), HasSubstr("larger than max"));
}

TEST_F(ValidationTest, TooLongTrajectoryForItsSamples) {
  v1::EvaluateRiskRequest eval = SmallCityPolyline();
  // 1e5 km at 5 m per sample: far past --max_eval_samples.
  eval.mutable_polyline()->mutable_points(2)->set_x(1e8);
  ExpectEvalError(eval, grpc::StatusCode::INVALID_ARGUMENT, "samples (length");
}

TEST_F(ValidationTest, MissingTrajectoryAndBadLayer) {
  v1::EvaluateRiskRequest eval;
  eval.set_map("demo-city");
  ExpectEvalError(eval, grpc::StatusCode::INVALID_ARGUMENT, "trajectory is required");
  v1::GetMapLayerRequest layer;
  layer.set_map("demo-city");
  v1::GetMapLayerResponse response;
  grpc::Status status = client_->GetMapLayer(layer, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(status.error_message(), HasSubstr("layer has value 0"));
}

TEST_F(ValidationTest, InadmissibleTrajectoryIsAnAnswerNotAnError) {
  v1::EvaluateRiskRequest eval = SmallCityPolyline();
  eval.mutable_polyline()->mutable_points(1)->set_z(100);  // into the ground
  v1::EvaluateRiskResponse response;
  grpc::Status status = client_->EvaluateRisk(eval, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_FALSE(response.admissible());
  ASSERT_TRUE(response.has_first_violation());
  EXPECT_NE(response.first_violation().kind(), v1::VIOLATION_KIND_UNSPECIFIED);
  EXPECT_GT(response.first_violation().arc_length_m(), 0.0);
  EXPECT_THAT(response.first_violation().message(),
              HasSubstr(v1::ViolationKind_Name(response.first_violation().kind())));
}

TEST_F(ValidationTest, BadRequestsNeverDisturbConcurrentGoodOnes) {
  // A reference run, then the same run while other threads hammer the server
  // with bad requests: same trajectory (iteration budget: deterministic).
  const v1::PlanRequest good = SmallCityPlan(0, 400);
  PlanOutcome reference = RunPlan(*client_, good);
  ASSERT_TRUE(reference.status.ok());
  v1::EvaluateRiskResponse eval_reference;
  ASSERT_TRUE(client_->EvaluateRisk(SmallCityPolyline(), &eval_reference).ok());

  std::atomic<bool> stop{false};
  std::atomic<int> bad_sent{0}, bad_refused{0};
  std::vector<std::thread> attackers;
  for (int t = 0; t < 3; ++t) {
    attackers.emplace_back([&, t] {
      client::RiskplanClient attacker(server_->Channel());
      while (!stop.load()) {
        v1::PlanRequest plan = SmallCityPlan(300);
        plan.mutable_start()->set_z(t == 0 ? kNaN : 5.0);
        PlanOutcome bad = RunPlan(attacker, plan);
        v1::EvaluateRiskRequest eval = SmallCityPolyline();
        eval.set_map("nowhere");
        v1::EvaluateRiskResponse response;
        grpc::Status status = attacker.EvaluateRisk(eval, &response);
        bad_sent += 2;
        bad_refused += (bad.status.error_code() == grpc::StatusCode::INVALID_ARGUMENT) +
                       (status.error_code() == grpc::StatusCode::NOT_FOUND);
      }
    });
  }
  // The attack is under way before the good run starts, however the
  // threads are scheduled, and lasts until it ends.
  const absl::Time attack_deadline = absl::Now() + absl::Seconds(60);
  while (bad_sent.load() == 0 && absl::Now() < attack_deadline) {
    absl::SleepFor(absl::Milliseconds(1));
  }
  if (bad_sent.load() == 0) {
    stop = true;
    for (std::thread& t : attackers) t.join();
    FAIL() << "no bad request was answered in 60 s";
  }
  PlanOutcome during = RunPlan(*client_, good);
  v1::EvaluateRiskResponse eval_during;
  grpc::Status eval_status = client_->EvaluateRisk(SmallCityPolyline(), &eval_during);
  stop = true;
  for (std::thread& t : attackers) t.join();

  ASSERT_TRUE(during.status.ok()) << during.status.error_message();
  EXPECT_EQ(during.updates.back().trajectory().risk(),
            reference.updates.back().trajectory().risk());
  EXPECT_EQ(during.updates.back().iterations(), 400);
  ASSERT_TRUE(eval_status.ok());
  EXPECT_EQ(eval_during.risk(), eval_reference.risk());
  EXPECT_GT(bad_sent.load(), 0);
  EXPECT_EQ(bad_refused.load(), bad_sent.load());
}

}  // namespace
}  // namespace riskplan::testing
