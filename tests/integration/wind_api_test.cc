// The wind through the real server (risk model version 3, docs/api.md
// "Wind"): bad winds refused naming the request's field, the wind echoed in
// every answer, the flight time and each sample's air heading and ground
// speed, a plan's times equal to its evaluation's, and GetRiskLayer for a
// heading and for the worst heading in wind.
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/integration/requests.h"
#include "tests/integration/server_process.h"
#include "tests/integration/shared_server_test.h"

namespace riskplan::testing {
namespace {

using ::testing::HasSubstr;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kPi = std::numbers::pi;

class WindApiTest : public SharedServerTest<WindApiTest> {
 protected:
  grpc::Status Eval(const v1::EvaluateRiskRequest& request, v1::EvaluateRiskResponse* response) {
    return client_->EvaluateRisk(request, response);
  }
  void ExpectEvalError(const v1::EvaluateRiskRequest& request, const std::string& message_part) {
    v1::EvaluateRiskResponse response;
    grpc::Status status = Eval(request, &response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
    EXPECT_THAT(status.error_message(), HasSubstr(message_part));
  }
};

v1::Wind WindFrom(double speed, double from_deg) {
  v1::Wind w;
  w.mutable_from()->set_speed_mps(speed);
  w.mutable_from()->set_from_deg(from_deg);
  return w;
}

// A straight level leg of 1400 m at 250 m AMSL from (300, y) to (1700, y),
// or northwards from (x, 300) to (x, 1700).
v1::EvaluateRiskRequest Leg(bool east) {
  v1::EvaluateRiskRequest r;
  r.set_map("demo-city");
  *r.mutable_polyline() = *client::ParsePolyline(east ? "300,1000,250; 1700,1000,250"
                                                      : "1000,300,250; 1000,1700,250");
  r.set_include_samples(true);
  return r;
}

TEST_F(WindApiTest, BadWindIsRefusedNamingTheField) {
  v1::EvaluateRiskRequest r = Leg(true);
  *r.mutable_wind() = WindFrom(10, 270);  // airspeed 18: at most 9 m/s
  ExpectEvalError(r, "wind.from.speed_mps has value 10; it must be at most 0.5 * "
                     "model_params.airspeed_mps = 9 m/s");
  *r.mutable_wind() = WindFrom(-1, 270);
  ExpectEvalError(r, "wind.from.speed_mps has value -1; a wind speed must be >= 0 m/s");
  *r.mutable_wind() = WindFrom(kNaN, 270);
  ExpectEvalError(r, "wind.from.speed_mps has value nan; it must be finite");
  *r.mutable_wind() = WindFrom(kInf, 270);
  ExpectEvalError(r, "wind.from.speed_mps has value inf; it must be finite");
  *r.mutable_wind() = WindFrom(5, kNaN);
  ExpectEvalError(r, "wind.from.from_deg has value nan; it must be finite");
  *r.mutable_wind() = WindFrom(5, -kInf);
  ExpectEvalError(r, "wind.from.from_deg has value -inf; it must be finite");
  r.mutable_wind()->mutable_vector()->set_x_mps(kInf);
  ExpectEvalError(r, "wind.vector.x_mps has value inf; it must be finite");
  r.mutable_wind()->mutable_vector()->set_x_mps(9);
  r.mutable_wind()->mutable_vector()->set_y_mps(1);
  ExpectEvalError(r, "wind.vector (x_mps 9, y_mps 1) has speed 9.05539 m/s; it must be at most");
  // A faster aircraft takes a stronger wind: the bound follows the airspeed.
  r.mutable_model_params()->set_airspeed_mps(20);
  v1::EvaluateRiskResponse ok;
  EXPECT_TRUE(Eval(r, &ok).ok());
  // The same checks on model_params' own wind fields.
  r = Leg(true);
  r.mutable_model_params()->set_wind_speed_mps(9.5);
  ExpectEvalError(r, "model_params: parameter 'wind_speed_mps' (9.5) must be at most 0.5 times "
                     "'airspeed_mps' (18)");
  r = Leg(true);
  r.mutable_model_params()->set_wind_from_deg(kInf);
  ExpectEvalError(r, "model_params");
  ExpectEvalError(r, "wind_from_deg");
  r = Leg(true);
  r.mutable_model_params()->set_wind_speed_mps(kNaN);
  ExpectEvalError(r, "wind_speed_mps");
  // The wind given twice.
  r = Leg(true);
  r.mutable_model_params()->set_wind_speed_mps(4);
  *r.mutable_wind() = WindFrom(5, 270);
  ExpectEvalError(r, "wind and model_params.wind_speed_mps both give the wind; give it once");
  // WGS84 on a map without a geo-reference.
  r = Leg(true);
  r.mutable_wind_wgs84()->mutable_from()->set_speed_mps(5);
  ExpectEvalError(r, "wind_wgs84: map 'demo-city' has no geo-reference");

  // PlanTrajectory and GetRiskLayer check the same way.
  v1::PlanRequest plan = SmallCityPlan(300);
  *plan.mutable_wind() = WindFrom(9.01, 0);
  PlanOutcome outcome = RunPlan(*client_, plan, absl::Seconds(30));
  EXPECT_EQ(outcome.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(outcome.status.error_message(), HasSubstr("wind.from.speed_mps has value 9.01"));
  EXPECT_TRUE(outcome.updates.empty());
  v1::GetRiskLayerRequest layer;
  layer.set_map("demo-city");
  layer.set_stride(40);
  *layer.mutable_wind() = WindFrom(3, kNaN);
  v1::GetRiskLayerResponse layer_response;
  grpc::Status status = client_->GetRiskLayer(layer, &layer_response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(status.error_message(), HasSubstr("wind.from.from_deg has value nan"));
}

TEST_F(WindApiTest, TheWindIsEchoedAndDirectionsAreTakenModulo360) {
  v1::EvaluateRiskRequest r = Leg(true);
  v1::EvaluateRiskResponse calm;
  ASSERT_TRUE(Eval(r, &calm).ok());
  EXPECT_EQ(calm.wind().speed_mps(), 0.0);
  EXPECT_EQ(calm.wind().airspeed_mps(), 18.0);
  EXPECT_EQ(calm.wind().glide_airspeed_mps(), 18.0);
  EXPECT_FALSE(calm.wind().has_from_true_deg());  // demo-city has no geo-reference

  *r.mutable_wind() = WindFrom(8, 270);
  v1::EvaluateRiskResponse west;
  ASSERT_TRUE(Eval(r, &west).ok());
  EXPECT_EQ(west.wind().speed_mps(), 8.0);
  EXPECT_EQ(west.wind().from_deg(), 270.0);
  EXPECT_NEAR(west.wind().x_mps(), 8.0, 1e-12);  // a west wind blows east
  EXPECT_NEAR(west.wind().y_mps(), 0.0, 1e-12);

  // 630 and -90 are 270: the same answer bit for bit.
  for (double from : {630.0, -90.0}) {
    *r.mutable_wind() = WindFrom(8, from);
    v1::EvaluateRiskResponse same;
    ASSERT_TRUE(Eval(r, &same).ok());
    EXPECT_EQ(same.wind().from_deg(), 270.0) << from;
    EXPECT_EQ(same.risk(), west.risk()) << from;
    EXPECT_EQ(same.flight_time_s(), west.flight_time_s()) << from;
  }
  // The vector form: the air moving east at 8 m/s is the wind from 270.
  r.mutable_wind()->mutable_vector()->set_x_mps(8);
  v1::EvaluateRiskResponse vector;
  ASSERT_TRUE(Eval(r, &vector).ok());
  EXPECT_EQ(vector.wind().from_deg(), 270.0);
  EXPECT_EQ(vector.wind().speed_mps(), 8.0);
  EXPECT_EQ(vector.risk(), west.risk());
  // model_params' fields give the same wind.
  r.clear_wind();
  r.mutable_model_params()->set_wind_speed_mps(8);
  r.mutable_model_params()->set_wind_from_deg(270);
  v1::EvaluateRiskResponse params;
  ASSERT_TRUE(Eval(r, &params).ok());
  EXPECT_EQ(params.risk(), west.risk());
  EXPECT_EQ(params.wind().from_deg(), 270.0);

  // A wind of 0 given explicitly is still air: the answer of no wind at all.
  r = Leg(true);
  *r.mutable_wind() = WindFrom(0, 123);
  v1::EvaluateRiskResponse zero;
  ASSERT_TRUE(Eval(r, &zero).ok());
  EXPECT_EQ(zero.risk(), calm.risk());
  EXPECT_EQ(zero.flight_time_s(), calm.flight_time_s());
  EXPECT_NE(west.risk(), calm.risk());

  // Every plan update carries the wind.
  v1::PlanRequest plan = SmallCityPlan(0, 300);
  *plan.mutable_wind() = WindFrom(5, 45);
  PlanOutcome outcome = RunPlan(*client_, plan, absl::Seconds(60));
  ASSERT_TRUE(outcome.status.ok()) << outcome.status.error_message();
  ASSERT_FALSE(outcome.updates.empty());
  for (const v1::PlanUpdate& u : outcome.updates) {
    EXPECT_EQ(u.wind().speed_mps(), 5.0);
    EXPECT_EQ(u.wind().from_deg(), 45.0);
  }
}

TEST_F(WindApiTest, FlightTimeAirHeadingAndGroundSpeedFollowTheWindTriangle) {
  const double v = 18.0, w = 8.0;
  // Still air: the ground speed is the airspeed and the air heading the track.
  v1::EvaluateRiskRequest r = Leg(true);
  v1::EvaluateRiskResponse calm;
  ASSERT_TRUE(Eval(r, &calm).ok());
  EXPECT_DOUBLE_EQ(calm.length_m(), 1400.0);
  EXPECT_EQ(calm.flight_time_s(), calm.length_m() / v);
  for (const v1::Sample& s : calm.samples()) {
    EXPECT_EQ(s.ground_speed_mps(), v);
    EXPECT_EQ(s.air_heading_rad(), s.theta());
  }
  // East in a west wind: a pure tail wind, v + W at every sample, the air
  // heading the track.
  *r.mutable_wind() = WindFrom(w, 270);
  v1::EvaluateRiskResponse tail;
  ASSERT_TRUE(Eval(r, &tail).ok());
  ASSERT_EQ(tail.samples_size(), 280);  // 1400 m every 5 m
  for (const v1::Sample& s : tail.samples()) {
    EXPECT_NEAR(s.ground_speed_mps(), v + w, 1e-12);
    EXPECT_NEAR(std::remainder(s.air_heading_rad() - s.theta(), 2 * kPi), 0.0, 1e-12);
  }
  EXPECT_NEAR(tail.flight_time_s(), 1400.0 / (v + w), 1e-9);
  ASSERT_EQ(tail.pieces_size(), 1);
  EXPECT_EQ(tail.pieces(0).flight_time_s(), tail.flight_time_s());
  EXPECT_EQ(tail.risk_per_flight_hour(), tail.risk() / (tail.flight_time_s() / 3600.0));
  // West into it: v - W.
  *r.mutable_polyline() = *client::ParsePolyline("1700,1000,250; 300,1000,250");
  v1::EvaluateRiskResponse head;
  ASSERT_TRUE(Eval(r, &head).ok());
  for (const v1::Sample& s : head.samples()) EXPECT_NEAR(s.ground_speed_mps(), v - w, 1e-12);
  EXPECT_NEAR(head.flight_time_s(), 1400.0 / (v - w), 1e-9);
  // North across it: the aircraft crabs left of the track into the wind,
  // psi = pi/2 + asin(W / v), and makes sqrt(v^2 - W^2) over the ground.
  r = Leg(false);
  *r.mutable_wind() = WindFrom(w, 270);
  v1::EvaluateRiskResponse cross;
  ASSERT_TRUE(Eval(r, &cross).ok());
  for (const v1::Sample& s : cross.samples()) {
    EXPECT_NEAR(s.ground_speed_mps(), std::sqrt(v * v - w * w), 1e-12);
    EXPECT_NEAR(s.air_heading_rad(), kPi / 2 + std::asin(w / v), 1e-12);
  }
  EXPECT_NEAR(cross.flight_time_s(), 1400.0 / std::sqrt(v * v - w * w), 1e-9);

  // The path of an evaluation carries the same triangle.
  r = Leg(true);
  r.set_include_samples(false);
  r.set_path_spacing_m(100);
  *r.mutable_wind() = WindFrom(w, 270);
  v1::EvaluateRiskResponse path;
  ASSERT_TRUE(Eval(r, &path).ok());
  ASSERT_EQ(path.path_size(), 15);
  for (const v1::PathSample& p : path.path()) EXPECT_NEAR(p.ground_speed_mps(), v + w, 1e-12);
}

TEST_F(WindApiTest, APlansTimesAndRiskAreItsEvaluationsInWind) {
  v1::PlanRequest plan = SmallCityPlan(0, 400);
  *plan.mutable_wind() = WindFrom(6, 300);
  PlanOutcome outcome = RunPlan(*client_, plan, absl::Seconds(60));
  ASSERT_TRUE(outcome.status.ok()) << outcome.status.error_message();
  ASSERT_FALSE(outcome.updates.empty());
  const v1::PlanUpdate& last = outcome.updates.back();
  ASSERT_TRUE(last.final());
  ASSERT_TRUE(last.has_trajectory());
  const v1::Trajectory& t = last.trajectory();
  ASSERT_EQ(t.path_air_heading_rad_size(), t.path_size());
  ASSERT_EQ(t.path_ground_speed_mps_size(), t.path_size());
  for (double gs : t.path_ground_speed_mps()) {
    EXPECT_GE(gs, 18.0 - 6.0 - 1e-9);
    EXPECT_LE(gs, 18.0 + 6.0 + 1e-9);
  }
  v1::EvaluateRiskRequest eval;
  eval.set_map("demo-city");
  *eval.mutable_waypoints()->mutable_poses() = t.waypoints();
  *eval.mutable_wind() = plan.wind();
  v1::EvaluateRiskResponse evaluation;
  ASSERT_TRUE(Eval(eval, &evaluation).ok());
  EXPECT_EQ(evaluation.risk(), t.risk());
  EXPECT_EQ(evaluation.length_m(), t.length_m());
  EXPECT_EQ(evaluation.flight_time_s(), t.flight_time_s());
  EXPECT_NE(t.flight_time_s(), t.length_m() / 18.0);
  EXPECT_EQ(evaluation.risk_per_flight_hour(), t.risk_per_flight_hour());
}

TEST_F(WindApiTest, RiskLayerForAHeadingAndTheWorstHeadingInWind) {
  v1::GetRiskLayerRequest request;
  request.set_map("demo-city");
  request.set_stride(20);
  request.set_heading_rad(0.0);
  v1::GetRiskLayerResponse calm;
  ASSERT_TRUE(client_->GetRiskLayer(request, &calm).ok());
  EXPECT_EQ(calm.wind().speed_mps(), 0.0);
  // Wind 0 given explicitly: the same layer bit for bit.
  v1::GetRiskLayerRequest zero = request;
  *zero.mutable_wind() = WindFrom(0, 90);
  v1::GetRiskLayerResponse zero_layer;
  ASSERT_TRUE(client_->GetRiskLayer(zero, &zero_layer).ok());
  ASSERT_EQ(zero_layer.risk_size(), calm.risk_size());
  for (int k = 0; k < calm.risk_size(); ++k) {
    if (std::isnan(calm.risk(k))) {
      EXPECT_TRUE(std::isnan(zero_layer.risk(k)));
    } else {
      EXPECT_EQ(zero_layer.risk(k), calm.risk(k)) << k;
    }
  }
  // In a north wind, flying east: the aircraft points left of the track and
  // the debris drifts south, so the layer changes.
  v1::GetRiskLayerRequest windy = request;
  *windy.mutable_wind() = WindFrom(8, 0);
  v1::GetRiskLayerResponse heading;
  ASSERT_TRUE(client_->GetRiskLayer(windy, &heading).ok());
  EXPECT_EQ(heading.wind().speed_mps(), 8.0);
  EXPECT_EQ(heading.heading_rad(), 0.0);
  ASSERT_EQ(heading.risk_size(), calm.risk_size());
  int differ = 0;
  for (int k = 0; k < calm.risk_size(); ++k) {
    differ += !std::isnan(calm.risk(k)) && !std::isnan(heading.risk(k)) &&
              calm.risk(k) != heading.risk(k);
  }
  EXPECT_GT(differ, 0);
  // The worst heading: at least the layer of track heading 0 (one of its
  // bins) wherever both are defined.
  windy.set_max_over_headings(true);
  v1::GetRiskLayerResponse worst;
  ASSERT_TRUE(client_->GetRiskLayer(windy, &worst).ok());
  EXPECT_TRUE(worst.max_over_headings());
  EXPECT_EQ(worst.wind().speed_mps(), 8.0);
  ASSERT_EQ(worst.risk_size(), heading.risk_size());
  int defined = 0;
  for (int k = 0; k < worst.risk_size(); ++k) {
    if (std::isnan(worst.risk(k)) || std::isnan(heading.risk(k))) continue;
    ++defined;
    EXPECT_GE(worst.risk(k), heading.risk(k)) << k;
  }
  EXPECT_GT(defined, 0);
}

}  // namespace
}  // namespace riskplan::testing
