// Validation at the edge: every bad input gets its code and a message naming
// the field and the value.
#include "server/api/request_validation.h"

#include <cmath>
#include <limits>

#include "absl/strings/str_format.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/core/test_maps.h"

namespace riskplan::server {
namespace {

using ::testing::HasSubstr;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

class RequestValidationTest : public ::testing::Test {
 protected:
  RequestValidationTest() {
    // 2 km x 2 km, flat terrain at 100 m AMSL.
    auto registry = MapRegistry::FromMaps(
        {testing_maps::UniformMap(200, 200, 10.0, 0.001f, 2.0f, 100.0f, {}, "test-city")});
    EXPECT_TRUE(registry.ok()) << registry.status();
    registry_ = *std::move(registry);
  }

  v1::PlanRequest GoodPlan() const {
    v1::PlanRequest r;
    r.set_map("test-city");
    r.mutable_start()->set_x(200);
    r.mutable_start()->set_y(200);
    r.mutable_start()->set_z(180);
    r.mutable_goal()->set_x(1800);
    r.mutable_goal()->set_y(1800);
    r.mutable_goal()->set_z(180);
    r.mutable_goal()->set_theta(-kPi / 2);
    r.mutable_budget()->set_time_ms(500);
    return r;
  }

  v1::EvaluateRiskRequest GoodEval() const {
    v1::EvaluateRiskRequest r;
    r.set_map("test-city");
    for (double x : {100.0, 1000.0, 1900.0}) {
      v1::Point3* p = r.mutable_polyline()->add_points();
      p->set_x(x);
      p->set_y(500);
      p->set_z(180);
    }
    return r;
  }

  void ExpectPlanError(const v1::PlanRequest& r, absl::StatusCode code,
                       const std::string& message_part) {
    absl::StatusOr<PlanSpec> spec = ValidatePlanRequest(r, *registry_, limits_);
    ASSERT_FALSE(spec.ok());
    EXPECT_EQ(spec.status().code(), code) << spec.status();
    EXPECT_THAT(std::string(spec.status().message()), HasSubstr(message_part));
  }

  void ExpectEvalError(const v1::EvaluateRiskRequest& r, absl::StatusCode code,
                       const std::string& message_part) {
    absl::StatusOr<EvaluateSpec> spec = ValidateEvaluateRequest(r, *registry_, limits_);
    ASSERT_FALSE(spec.ok());
    EXPECT_EQ(spec.status().code(), code) << spec.status();
    EXPECT_THAT(std::string(spec.status().message()), HasSubstr(message_part));
  }

  std::unique_ptr<MapRegistry> registry_;
  RequestLimits limits_;
};

TEST_F(RequestValidationTest, GoodPlanRequest) {
  absl::StatusOr<PlanSpec> spec = ValidatePlanRequest(GoodPlan(), *registry_, limits_);
  ASSERT_TRUE(spec.ok()) << spec.status();
  EXPECT_EQ(spec->map->name(), "test-city");
  EXPECT_EQ(spec->algorithm, PlannerAlgorithm::kRiskRrtStar);
  EXPECT_DOUBLE_EQ(spec->options.budget.max_time_s, 0.5);
  EXPECT_EQ(spec->options.budget.max_iterations, 0);
  // Headings are normalised into [0, 2 pi).
  EXPECT_DOUBLE_EQ(spec->goal.theta, 1.5 * kPi);
  EXPECT_DOUBLE_EQ(spec->display_step_m, 25.0);
  EXPECT_EQ(spec->min_update_interval, absl::ZeroDuration());
}

TEST_F(RequestValidationTest, BudgetDefaultsAndCaps) {
  v1::PlanRequest r = GoodPlan();
  r.clear_budget();
  absl::StatusOr<PlanSpec> spec = ValidatePlanRequest(r, *registry_, limits_);
  ASSERT_TRUE(spec.ok());
  EXPECT_DOUBLE_EQ(spec->options.budget.max_time_s, 1.0);  // default_plan_time_ms
  r.mutable_budget()->set_iterations(5000);
  spec = ValidatePlanRequest(r, *registry_, limits_);
  ASSERT_TRUE(spec.ok());
  EXPECT_EQ(spec->options.budget.max_iterations, 5000);
  EXPECT_DOUBLE_EQ(spec->options.budget.max_time_s, 600.0);  // the wall-time cap
}

TEST_F(RequestValidationTest, UnknownMapIsNotFound) {
  v1::PlanRequest r = GoodPlan();
  r.set_map("atlantis");
  ExpectPlanError(r, absl::StatusCode::kNotFound,
                  "map 'atlantis' is not served; served maps: test-city");
  r.set_map("");
  ExpectPlanError(r, absl::StatusCode::kInvalidArgument, "map is required");
}

TEST_F(RequestValidationTest, NonFinitePoseNamesTheField) {
  v1::PlanRequest r = GoodPlan();
  r.mutable_start()->set_z(kNaN);
  ExpectPlanError(r, absl::StatusCode::kInvalidArgument, "start.z has value nan");
  r = GoodPlan();
  r.mutable_goal()->set_theta(kInf);
  ExpectPlanError(r, absl::StatusCode::kInvalidArgument, "goal.theta has value inf");
  r = GoodPlan();
  r.clear_goal();
  ExpectPlanError(r, absl::StatusCode::kInvalidArgument, "goal is required");
}

TEST_F(RequestValidationTest, PoseOutsideTheMap) {
  v1::PlanRequest r = GoodPlan();
  r.mutable_goal()->set_x(2500);
  ExpectPlanError(r, absl::StatusCode::kInvalidArgument,
                  "goal (x, y) = (2500, 1800) is outside map 'test-city', which covers x in "
                  "[0, 2000), y in [0, 2000)");
}

TEST_F(RequestValidationTest, Algorithms) {
  v1::PlanRequest r = GoodPlan();
  r.set_algorithm(static_cast<v1::Algorithm>(7));
  ExpectPlanError(r, absl::StatusCode::kInvalidArgument, "algorithm has value 7");
  const std::pair<v1::Algorithm, PlannerAlgorithm> known[] = {
      {v1::ALGORITHM_UNSPECIFIED, PlannerAlgorithm::kRiskRrtStar},
      {v1::RISK_RRT_STAR, PlannerAlgorithm::kRiskRrtStar},
      {v1::RRT, PlannerAlgorithm::kRrt},
      {v1::GENETIC, PlannerAlgorithm::kGenetic},
      {v1::HARMONIC, PlannerAlgorithm::kHarmonic}};
  for (auto [proto, algorithm] : known) {
    r.set_algorithm(proto);
    absl::StatusOr<PlanSpec> spec = ValidatePlanRequest(r, *registry_, limits_);
    ASSERT_TRUE(spec.ok()) << spec.status();
    EXPECT_EQ(spec->algorithm, algorithm);
  }
}

TEST_F(RequestValidationTest, ObstaclesReachThePlanOptions) {
  v1::PlanRequest r = GoodPlan();
  r.set_algorithm(v1::HARMONIC);  // takes both kinds of request obstacles
  r.add_obstacle_points()->set_x(700);
  v1::DynamicObstacle* o = r.add_dynamic_obstacles();
  o->set_at_iteration(50);
  o->set_x0_m(100);
  o->set_y0_m(200);
  o->set_x1_m(300);
  o->set_y1_m(400);
  absl::StatusOr<PlanSpec> spec = ValidatePlanRequest(r, *registry_, limits_);
  ASSERT_TRUE(spec.ok()) << spec.status();
  ASSERT_EQ(spec->options.obstacle_points.size(), 1u);
  EXPECT_EQ(spec->options.obstacle_points[0].x, 700);
  ASSERT_EQ(spec->options.dynamic_obstacles.size(), 1u);
  EXPECT_EQ(spec->options.dynamic_obstacles[0].at_iteration, 50);
  EXPECT_EQ(spec->options.dynamic_obstacles[0].y1_m, 400);
  limits_.max_obstacle_points = 0;
  // Only local points: the message names only them.
  ExpectPlanError(r, absl::StatusCode::kInvalidArgument,
                  "obstacle_points has 1 points; the limit is 0");
}

TEST_F(RequestValidationTest, PlannersThatCannotHonourObstaclesRefuseThem) {
  v1::PlanRequest r = GoodPlan();
  r.set_algorithm(v1::RISK_RRT_STAR);
  r.add_obstacle_points()->set_x(700);
  ExpectPlanError(r, absl::StatusCode::kInvalidArgument,
                  "obstacle_points: RISK_RRT_STAR does not take request obstacles");
  r = GoodPlan();
  r.set_algorithm(v1::RRT);
  v1::DynamicObstacle* o = r.add_dynamic_obstacles();
  o->set_x1_m(10);
  o->set_y1_m(10);
  ExpectPlanError(r, absl::StatusCode::kInvalidArgument,
                  "dynamic_obstacles: RRT does not take obstacles that appear while it runs");
}

TEST_F(RequestValidationTest, BudgetOutOfRange) {
  v1::PlanRequest r = GoodPlan();
  r.mutable_budget()->set_time_ms(-1);
  ExpectPlanError(r, absl::StatusCode::kInvalidArgument, "budget.time_ms has value -1");
  r.mutable_budget()->set_time_ms(600001);
  ExpectPlanError(r, absl::StatusCode::kInvalidArgument,
                  "budget.time_ms has value 600001; it must be in [0, 600000]");
  r = GoodPlan();
  r.mutable_budget()->set_iterations(-5);
  ExpectPlanError(r, absl::StatusCode::kInvalidArgument, "budget.iterations has value -5");
}

TEST_F(RequestValidationTest, ModelParamsOutOfRange) {
  v1::PlanRequest r = GoodPlan();
  r.mutable_model_params()->set_mass_kg(-3);
  ExpectPlanError(r, absl::StatusCode::kInvalidArgument,
                  "model_params: parameter 'mass_kg' has value -3");
  r = GoodPlan();
  r.mutable_model_params()->set_airspeed_mps(kNaN);
  ExpectPlanError(r, absl::StatusCode::kInvalidArgument,
                  "model_params: parameter 'airspeed_mps' has value nan");
  r = GoodPlan();
  r.mutable_model_params()->set_heading_bins(0);
  ExpectPlanError(r, absl::StatusCode::kInvalidArgument, "'heading_bins' has value 0");
}

TEST_F(RequestValidationTest, PlannerParams) {
  v1::PlanRequest r = GoodPlan();
  (*r.mutable_planner_params())["no_such_param"] = 1.0;
  ExpectPlanError(r, absl::StatusCode::kInvalidArgument,
                  "planner_params: unknown parameter 'no_such_param' for RISK_RRT_STAR");
  const PlannerParamInfo& first = PlannerParams(PlannerAlgorithm::kRiskRrtStar).front();
  r = GoodPlan();
  (*r.mutable_planner_params())[first.name] = first.max_value + 1.0;
  ExpectPlanError(r, absl::StatusCode::kInvalidArgument,
                  "planner_params['" + first.name + "'] has value");
  r = GoodPlan();
  (*r.mutable_planner_params())[first.name] = first.default_value;
  absl::StatusOr<PlanSpec> spec = ValidatePlanRequest(r, *registry_, limits_);
  ASSERT_TRUE(spec.ok()) << spec.status();
  EXPECT_EQ(spec->options.params.at(first.name), first.default_value);
}

TEST_F(RequestValidationTest, IntervalAndDisplayStep) {
  v1::PlanRequest r = GoodPlan();
  r.set_min_update_interval_ms(-10);
  ExpectPlanError(r, absl::StatusCode::kInvalidArgument, "min_update_interval_ms has value -10");
  r = GoodPlan();
  r.set_display_step_m(0.5);
  ExpectPlanError(r, absl::StatusCode::kInvalidArgument, "display_step_m has value 0.5");
}

TEST_F(RequestValidationTest, GoodEvaluateRequest) {
  absl::StatusOr<EvaluateSpec> spec = ValidateEvaluateRequest(GoodEval(), *registry_, limits_);
  ASSERT_TRUE(spec.ok()) << spec.status();
  EXPECT_EQ(spec->polyline.size(), 3u);
  EXPECT_TRUE(spec->waypoints.empty());
}

TEST_F(RequestValidationTest, EvaluateErrors) {
  v1::EvaluateRiskRequest r = GoodEval();
  r.mutable_polyline()->mutable_points(1)->set_y(kNaN);
  ExpectEvalError(r, absl::StatusCode::kInvalidArgument, "polyline.points[1].y has value nan");

  r = GoodEval();
  r.clear_polyline();
  ExpectEvalError(r, absl::StatusCode::kInvalidArgument, "trajectory is required");

  r = GoodEval();
  r.mutable_polyline()->mutable_points()->DeleteSubrange(1, 2);
  ExpectEvalError(r, absl::StatusCode::kInvalidArgument,
                  "polyline.points has 1 points; it must have 2 to 10000");

  r = GoodEval();
  limits_.max_waypoints = 4;
  for (int i = 0; i < 5; ++i) {
    v1::Pose* p = r.mutable_waypoints()->add_poses();
    p->set_x(100 + 100 * i);
    p->set_y(100);
    p->set_z(180);
  }
  ExpectEvalError(r, absl::StatusCode::kInvalidArgument,
                  "waypoints.poses has 5 poses; it must have 2 to 4");

  r = GoodEval();
  r.set_map("nowhere");
  ExpectEvalError(r, absl::StatusCode::kNotFound, "map 'nowhere' is not served");
}

TEST_F(RequestValidationTest, TwoTierOptions) {
  v1::EvaluateRiskRequest r = GoodEval();
  absl::StatusOr<EvaluateSpec> spec = ValidateEvaluateRequest(r, *registry_, limits_);
  ASSERT_TRUE(spec.ok()) << spec.status();
  EXPECT_FALSE(spec->two_tier.has_value());  // not asked for

  // Unset fields take the checker's defaults.
  r.mutable_two_tier()->set_enabled(true);
  spec = ValidateEvaluateRequest(r, *registry_, limits_);
  ASSERT_TRUE(spec.ok()) << spec.status();
  ASSERT_TRUE(spec->two_tier.has_value());
  EXPECT_EQ(spec->two_tier->rule, CollisionRule::kFlightBand);
  EXPECT_EQ(spec->two_tier->detailed_segments, 2);
  EXPECT_EQ(spec->two_tier->block_cells, 16);
  EXPECT_EQ(spec->two_tier->traversal, CellTraversal::kSupercover);

  // Every field reaches the options; 0 detailed segments is allowed.
  r.mutable_two_tier()->set_rule(v1::TERRAIN_ONLY);
  r.mutable_two_tier()->set_detailed_segments(0);
  r.mutable_two_tier()->set_block_cells(8);
  r.mutable_two_tier()->set_bresenham(true);
  spec = ValidateEvaluateRequest(r, *registry_, limits_);
  ASSERT_TRUE(spec.ok()) << spec.status();
  EXPECT_EQ(spec->two_tier->rule, CollisionRule::kTerrain);
  EXPECT_EQ(spec->two_tier->detailed_segments, 0);
  EXPECT_EQ(spec->two_tier->block_cells, 8);
  EXPECT_EQ(spec->two_tier->traversal, CellTraversal::kBresenham);
}

TEST_F(RequestValidationTest, TwoTierOptionErrorsNameTheField) {
  v1::EvaluateRiskRequest r = GoodEval();
  r.mutable_two_tier()->set_enabled(true);
  r.mutable_two_tier()->set_detailed_segments(-1);
  ExpectEvalError(r, absl::StatusCode::kInvalidArgument,
                  "two_tier.detailed_segments has value -1; it must be >= 0");

  for (int cells : {0, 1025}) {
    r = GoodEval();
    r.mutable_two_tier()->set_enabled(true);
    r.mutable_two_tier()->set_block_cells(cells);
    ExpectEvalError(r, absl::StatusCode::kInvalidArgument,
                    absl::StrFormat("two_tier: two-tier feasibility: block_cells is %d; it must "
                                    "be in [1, 1024]",
                                    cells));
  }

  r = GoodEval();
  r.mutable_two_tier()->set_enabled(true);
  r.mutable_two_tier()->set_rule(static_cast<v1::CollisionRule>(7));
  ExpectEvalError(r, absl::StatusCode::kInvalidArgument, "two_tier.rule has value 7");

  // Refused even when the check is not enabled.
  r = GoodEval();
  r.mutable_two_tier()->set_block_cells(0);
  ExpectEvalError(r, absl::StatusCode::kInvalidArgument, "block_cells is 0");
}

TEST_F(RequestValidationTest, SampleCountLimits) {
  EXPECT_TRUE(CheckSampleCount(1000, 5000, 5, true, limits_).ok());
  absl::Status s = CheckSampleCount(3000000, 15e6, 5, false, limits_);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(s.message()), HasSubstr("trajectory has 3000000 samples"));
  s = CheckSampleCount(300000, 1.5e6, 5, true, limits_);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(s.message()), HasSubstr("include_samples"));
}

// The API's ModelParameters and core's ModelParams have the same field names,
// so that an override set in one reaches the other.
TEST(ModelParametersTest, ProtoFieldsMatchModelParamNames) {
  const google::protobuf::Descriptor* d = v1::ModelParameters::descriptor();
  ASSERT_EQ(d->field_count(), static_cast<int>(ModelParamNames().size()));
  for (std::string_view name : ModelParamNames()) {
    EXPECT_NE(d->FindFieldByName(std::string(name)), nullptr) << name;
  }
}

TEST(ModelParametersTest, EveryFieldReachesModelParams) {
  v1::ModelParameters proto;
  proto.set_mass_kg(12.5);
  proto.set_heading_bins(36);
  proto.set_glide_ratio(8);
  absl::StatusOr<ModelParams> params = ModelParamsFromProto(proto);
  ASSERT_TRUE(params.ok()) << params.status();
  EXPECT_EQ(params->mass_kg, 12.5);
  EXPECT_EQ(params->heading_bins, 36);
  EXPECT_EQ(params->glide_ratio, 8.0);
  EXPECT_EQ(params->airspeed_mps, ModelParams{}.airspeed_mps);  // unset keeps its default
}

// --max_table_bytes on the gRPC thread: the table's lower bound (one row of
// weights per kernel) at, just under and just over the limit.
TEST_F(RequestValidationTest, ImpactTableBytesAtUnderAndOverTheLimit) {
  v1::PlanRequest r = GoodPlan();
  r.mutable_model_params()->set_heading_bins(3600);
  ModelParams p;
  p.heading_bins = 3600;
  const double min_bytes = ImpactTable::MinBytes(p);
  limits_.max_table_bytes = static_cast<size_t>(min_bytes);
  EXPECT_TRUE(ValidatePlanRequest(r, *registry_, limits_).ok());
  limits_.max_table_bytes = static_cast<size_t>(min_bytes) + 1;
  EXPECT_TRUE(ValidatePlanRequest(r, *registry_, limits_).ok());
  limits_.max_table_bytes = static_cast<size_t>(min_bytes) - 1;
  const std::string message = absl::StrFormat(
      "model_params: the impact table of 'heading_bins' 3600 x 60 height bins "
      "('table_max_height_m' 300 / 'height_bin_m' 5), kernels of up to 63 x 64 weights "
      "('max_half_width' 31), needs at least %.0f bytes; the limit is %d bytes "
      "(--max_table_bytes)",
      min_bytes, limits_.max_table_bytes);
  ExpectPlanError(r, absl::StatusCode::kInvalidArgument, message);
  v1::EvaluateRiskRequest e = GoodEval();
  e.mutable_model_params()->set_heading_bins(3600);
  ExpectEvalError(e, absl::StatusCode::kInvalidArgument, message);
}

// The issue's terabyte table: every value in range, refused before queueing.
TEST_F(RequestValidationTest, ATerabyteImpactTableIsRefused) {
  v1::EvaluateRiskRequest e = GoodEval();
  e.mutable_model_params()->set_heading_bins(3600);
  e.mutable_model_params()->set_height_bin_m(0.5);
  e.mutable_model_params()->set_table_max_height_m(5000);
  ModelParams p;
  p.heading_bins = 3600;
  p.height_bin_m = 0.5;
  p.table_max_height_m = 5000;
  ExpectEvalError(
      e, absl::StatusCode::kInvalidArgument,
      absl::StrFormat("model_params: the impact table of 'heading_bins' 3600 x 10000 height bins "
                      "('table_max_height_m' 5000 / 'height_bin_m' 0.5), kernels of up to 63 x "
                      "64 weights ('max_half_width' 31), needs at least %.0f bytes; the limit is "
                      "536870912 bytes (--max_table_bytes)",
                      ImpactTable::MinBytes(p)));
  EXPECT_GT(ImpactTable::MinBytes(p), 3e9);
}

// --max_edge_samples: the projection for this map (2 km square, flat at
// 100 m, ceiling 250 m) is 714 samples per edge at the default 5 m.
TEST_F(RequestValidationTest, EdgeSamplesAtUnderAndOverTheLimit) {
  const v1::PlanRequest r = GoodPlan();
  limits_.max_edge_samples = 714;
  absl::StatusOr<PlanSpec> spec = ValidatePlanRequest(r, *registry_, limits_);
  ASSERT_TRUE(spec.ok()) << spec.status();
  EXPECT_EQ(spec->options.max_edge_samples, 714);  // the planner checks it again
  limits_.max_edge_samples = 715;
  EXPECT_TRUE(ValidatePlanRequest(r, *registry_, limits_).ok());
  limits_.max_edge_samples = 713;
  ExpectPlanError(r, absl::StatusCode::kInvalidArgument,
                  "model_params: an edge of a RISK_RRT_STAR plan on map 'test-city' may need 714 "
                  "samples: up to 3559.9 m long (the map's diagonal 2828.4 m, turn_radius_m 50, "
                  "climbs of up to 150.0 m at max_climb_rad 0.15) sampled every 5 m "
                  "(sample_step_m); the limit is 713 samples per edge (--max_edge_samples)");
  // A finer step, a smaller climb angle or GENETIC's risk step make more.
  limits_.max_edge_samples = kDefaultMaxEdgeSamples;
  v1::PlanRequest fine = GoodPlan();
  fine.mutable_model_params()->set_sample_step_m(0.1);
  fine.mutable_model_params()->set_max_climb_rad(0.01);
  fine.mutable_model_params()->set_turn_radius_m(10000);
  ExpectPlanError(fine, absl::StatusCode::kInvalidArgument, "may need 1484925 samples");
  v1::PlanRequest genetic = GoodPlan();
  genetic.set_algorithm(v1::GENETIC);
  (*genetic.mutable_planner_params())["risk_step_m"] = 1.0;
  limits_.max_edge_samples = 3000;
  ExpectPlanError(genetic, absl::StatusCode::kInvalidArgument,
                  "sampled every 1 m (sample_step_m or risk_step_m); the limit is 3000");
}

// The issue's adversarial values, every one inside the old documented
// ranges, each refused naming the field, its value and the range.
TEST_F(RequestValidationTest, TheIssuesModelParametersAreRefused) {
  struct Case {
    void (*set)(v1::ModelParameters*);
    const char* message;
  };
  const Case cases[] = {
      {[](v1::ModelParameters* m) { m->set_sample_step_m(1e-7); },
       "model_params: parameter 'sample_step_m' has value 1e-07; it must be finite and in "
       "[0.1, 1000]"},
      {[](v1::ModelParameters* m) { m->set_sample_step_m(5e-6); },
       "model_params: parameter 'sample_step_m' has value 5e-06"},
      {[](v1::ModelParameters* m) { m->set_turn_radius_m(1e-9); },
       "model_params: parameter 'turn_radius_m' has value 1e-09; it must be finite and in "
       "[1, 10000]"},
      {[](v1::ModelParameters* m) { m->set_turn_radius_m(2.2e-308); },
       "model_params: parameter 'turn_radius_m' has value 2.2e-308"},
      {[](v1::ModelParameters* m) { m->set_gravity_mps2(1e-300); },
       "model_params: parameter 'gravity_mps2' has value 1e-300; it must be finite and in "
       "[0.1, 30]"},
      {[](v1::ModelParameters* m) { m->set_mass_kg(1e-300); },
       "model_params: parameter 'mass_kg' has value 1e-300; it must be finite and in "
       "[0.01, 1000]"},
      {[](v1::ModelParameters* m) { m->set_beta_j(5e-324); },
       "model_params: parameter 'beta_j' has value 4.94066e-324; it must be finite and in "
       "[1, 1e+12]"},
      {[](v1::ModelParameters* m) { m->set_max_climb_rad(1e-12); },
       "model_params: parameter 'max_climb_rad' has value 1e-12; it must be finite and in "
       "[0.01, 1.4]"},
  };
  for (const Case& c : cases) {
    v1::PlanRequest plan = GoodPlan();
    c.set(plan.mutable_model_params());
    ExpectPlanError(plan, absl::StatusCode::kInvalidArgument, c.message);
    v1::EvaluateRiskRequest eval = GoodEval();
    c.set(eval.mutable_model_params());
    ExpectEvalError(eval, absl::StatusCode::kInvalidArgument, c.message);
  }
}

// Saturating sums (planner_service's Evaluate adds PartCount per piece):
// the counts of the issue's polylines, each far over the limit, never wrap.
TEST(SampleCountTest, TheIssuesPolylinesAreOverTheLimitNotNegative) {
  RequestLimits limits;
  const absl::Status one = CheckSampleCount(kMaxPartCount, 1e19, 5.0, false, limits);
  EXPECT_EQ(one.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(one.message()), HasSubstr("the limit is 2000000"));
  EXPECT_TRUE(CheckSampleCount(limits.max_eval_samples, 1e7, 5.0, false, limits).ok());
  EXPECT_FALSE(CheckSampleCount(limits.max_eval_samples + 1, 1e7, 5.0, false, limits).ok());
  EXPECT_TRUE(CheckSampleCount(limits.max_response_samples, 1e6, 5.0, true, limits).ok());
  EXPECT_FALSE(CheckSampleCount(limits.max_response_samples + 1, 1e6, 5.0, true, limits).ok());
}

}  // namespace
}  // namespace riskplan::server
