// No single request can crash the server or get a wrong answer: the requests
// of an adversarial client that keeps every value inside the documented
// ranges, each refused with its status code and a message naming the field,
// the amount and the limit, through the real server and client; a flood of
// them beside a good plan that stays bit for bit what it is alone; bytes that
// are not a request; and a drain that ends such work in flight.
#include <signal.h>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <memory>
#include <mutex>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_format.h"
#include "absl/synchronization/mutex.h"
#include "gmock/gmock.h"
#include "grpcpp/generic/generic_stub.h"
#include "gtest/gtest.h"
#include "tests/integration/requests.h"
#include "tests/integration/server_process.h"
#include "tests/integration/shared_server_test.h"

namespace riskplan::testing {
namespace {

using ::testing::HasSubstr;

constexpr int64_t kMaxEdgeSamples = 100000;

v1::EvaluateRiskRequest Eval(const std::string& polyline, const std::string& params = "") {
  v1::EvaluateRiskRequest r;
  r.set_map("demo-city");
  *r.mutable_polyline() = *client::ParsePolyline(polyline);
  EXPECT_TRUE(client::ParseModelParameters(params, r.mutable_model_params()).ok()) << params;
  return r;
}

v1::EvaluateRiskRequest EvalWaypoints(const std::string& waypoints, const std::string& params) {
  v1::EvaluateRiskRequest r;
  r.set_map("demo-city");
  *r.mutable_waypoints() = *client::ParseWaypoints(waypoints);
  EXPECT_TRUE(client::ParseModelParameters(params, r.mutable_model_params()).ok()) << params;
  return r;
}

v1::PlanRequest Plan(int64_t time_ms, const std::string& params, v1::Algorithm algorithm) {
  v1::PlanRequest r = SmallCityPlan(time_ms);
  r.set_algorithm(algorithm);
  EXPECT_TRUE(client::ParseModelParameters(params, r.mutable_model_params()).ok()) << params;
  return r;
}

// An adversarial request and what it must get.
struct Expected {
  grpc::StatusCode code;
  std::vector<std::string> message_parts;
};

struct AdversarialEval {
  std::string what;
  v1::EvaluateRiskRequest request;
  Expected expected;
};

struct AdversarialPlan {
  std::string what;
  v1::PlanRequest request;
  Expected expected;
};

// The requests (every value inside the ranges documented before),
// each with the status code and the message parts that name the field, the
// amount and the limit.
std::vector<AdversarialEval> AdversarialEvals() {
  const grpc::StatusCode kInvalid = grpc::StatusCode::INVALID_ARGUMENT;
  return {
      {"a sample count over int through a no-fly zone",
       Eval("4000,4275,250;4800,4275,250", "sample_step_m=1e-7"),
       {kInvalid,
        {"model_params: parameter 'sample_step_m' has value 1e-07; it must be finite and in "
         "[0.1, 1000]"}}},
      {"a segment of 1e19 m",
       Eval("0,0,250;1e19,0,250"),
       {kInvalid,
        {"trajectory has 2000000000000000000 samples (length 10000000000000000000.0 m at "
         "sample_step_m 5); the limit is 2000000"}}},
      {"counts whose sum overflowed",
       Eval("1000,1000,250;1000,1e10,250;1e19,1000,250"),
       {kInvalid, {"trajectory has 2000000001999999800 samples", "; the limit is 2000000"}}},
      {"a terabyte impact table",
       Eval("1000,1000,250;2000,1000,250",
            "heading_bins=3600,height_bin_m=0.5,"
            "table_max_height_m=5000"),
       {kInvalid,
        {"model_params: the impact table of 'heading_bins' 3600 x 10000 height bins "
         "('table_max_height_m' 5000 / 'height_bin_m' 0.5)",
         "re:needs at least [0-9]{10} bytes; the limit is 536870912 bytes "
         "\\(--max_table_bytes\\)"}}},
      {"a turning radius that wrapped a spiral",
       EvalWaypoints("1000,1000,200,0;1300,1000,300,0", "turn_radius_m=1e-9"),
       {kInvalid,
        {"model_params: parameter 'turn_radius_m' has value 1e-09; it must be finite and in "
         "[1, 10000]"}}},
      {"a gravity that never lands",
       Eval("1000,1000,250;2000,1000,250", "gravity_mps2=1e-300"),
       {kInvalid,
        {"model_params: parameter 'gravity_mps2' has value 1e-300; it must be finite and in "
         "[0.1, 30]"}}},
      {"a mass that never lands",
       Eval("1000,1000,250;2000,1000,250", "mass_kg=1e-300"),
       {kInvalid,
        {"model_params: parameter 'mass_kg' has value 1e-300; it must be finite and in "
         "[0.01, 1000]"}}},
      {"a beta that made the risk NaN",
       Eval("1000,1000,250;2000,1000,250", "beta_j=5e-324"),
       {kInvalid,
        {"model_params: parameter 'beta_j' has value 4.94066e-324; it must be finite and in "
         "[1, 1e+12]"}}},
      {"a fall that lasts days",
       Eval("1000,1000,250;2000,1000,250",
            "mass_kg=0.01,drag_coefficient=10,frontal_area_m2=100,air_density_kgpm3=10"),
       {kInvalid, {"give a terminal velocity of 0.00443 m/s", "at most 10000 s of fall"}}},
  };
}

std::vector<AdversarialPlan> AdversarialPlans() {
  const grpc::StatusCode kInvalid = grpc::StatusCode::INVALID_ARGUMENT;
  return {
      {"a plan sampled every 5 um",
       Plan(100, "sample_step_m=5e-6", v1::RISK_RRT_STAR),
       {kInvalid, {"model_params: parameter 'sample_step_m' has value 5e-06"}}},
      {"GENETIC with pieces of 1e14 m",
       Plan(100, "max_climb_rad=1e-12", v1::GENETIC),
       {kInvalid,
        {"model_params: parameter 'max_climb_rad' has value 1e-12; it must be finite and in "
         "[0.01, 1.4]"}}},
      {"edges past --max_edge_samples",
       Plan(100, "sample_step_m=0.1,max_climb_rad=0.01,turn_radius_m=10000", v1::RRT),
       {kInvalid,
        {"model_params: an edge of a RRT plan on map 'demo-city' may need ",
         "sampled every 0.1 m (sample_step_m); the limit is 100000 samples per edge "
         "(--max_edge_samples)"}}},
      {"a terabyte impact table for a plan",
       Plan(100, "heading_bins=3600,height_bin_m=0.5,table_max_height_m=5000", v1::HARMONIC),
       {kInvalid, {"; the limit is 536870912 bytes (--max_table_bytes)"}}},
  };
}

// "" when `status` is what `expected` says, else what differs.
std::string Mismatch(const grpc::Status& status, const Expected& expected) {
  if (status.error_code() != expected.code) {
    return absl::StrFormat("code %s, not %s: %s", client::StatusCodeName(status.error_code()),
                           client::StatusCodeName(expected.code), status.error_message());
  }
  for (const std::string& part : expected.message_parts) {
    // "re:" marks a regular expression (for amounts that depend on the build).
    if (absl::StartsWith(part, "re:")) {
      if (!std::regex_search(status.error_message(), std::regex(part.substr(3)))) {
        return absl::StrFormat("message '%s' does not match '%s'", status.error_message(), part);
      }
      continue;
    }
    if (status.error_message().find(part) == std::string::npos) {
      return absl::StrFormat("message '%s' lacks '%s'", status.error_message(), part);
    }
  }
  return "";
}

class HardLimitsTest : public SharedServerTest<HardLimitsTest> {
 public:
  static std::vector<std::string> ServerFlags() {
    return {absl::StrFormat("--max_edge_samples=%d", kMaxEdgeSamples), "--plan_threads=2"};
  }
};

TEST_F(HardLimitsTest, EveryAdversarialEvaluationGetsItsCodeAndAMessageWithTheLimit) {
  for (const AdversarialEval& c : AdversarialEvals()) {
    v1::EvaluateRiskResponse response;
    const grpc::Status status = client_->EvaluateRisk(c.request, &response);
    EXPECT_EQ(Mismatch(status, c.expected), "") << c.what;
  }
  // The server is still serving, and answers the good request next to them.
  EXPECT_TRUE(client_->Ping().ok());
  v1::EvaluateRiskResponse good;
  ASSERT_TRUE(client_->EvaluateRisk(SmallCityPolyline(), &good).ok());
  EXPECT_TRUE(std::isfinite(good.risk()));
}

TEST_F(HardLimitsTest, EveryAdversarialPlanGetsItsCodeAndAMessageWithTheLimit) {
  for (const AdversarialPlan& c : AdversarialPlans()) {
    const PlanOutcome plan = RunPlan(*client_, c.request, absl::Seconds(60));
    EXPECT_EQ(Mismatch(plan.status, c.expected), "") << c.what;
    EXPECT_TRUE(plan.updates.empty()) << c.what;
  }
}

// The climb of the issue with a turning radius that is in range: the spiral
// is flown, so the trajectory is as long as the climb limit makes it.
TEST_F(HardLimitsTest, ASteepClimbIsFlownAsASpiral) {
  v1::EvaluateRiskResponse response;
  const grpc::Status status = client_->EvaluateRisk(
      EvalWaypoints("1000,1000,200,0;1300,1000,300,0", "turn_radius_m=1"), &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_GE(response.length_m(), 100.0 / std::sin(0.15) - 1e-6);
}

// Parameters at the edges of their ranges still give finite numbers.
TEST_F(HardLimitsTest, ParametersAtTheirBoundsGiveFiniteAnswers) {
  for (const std::string params :
       {"beta_j=1,alpha_j=1e12,sigma_pos_m=0.01,sigma_wind_mps=0,sigma_speed_mps=0",
        "airspeed_mps=1,turn_radius_m=1,max_climb_rad=1.4,sample_step_m=0.1",
        "height_bin_m=0.1,table_max_height_m=1,gravity_mps2=30,mass_kg=1000",
        "gravity_mps2=0.1,mass_kg=0.01,drag_coefficient=0,failure_rate_per_s=1",
        "airspeed_mps=200,person_radius_m=10,person_height_m=10,uav_radius_m=50"}) {
    v1::EvaluateRiskResponse response;
    const grpc::Status status =
        client_->EvaluateRisk(Eval("300,375,240;1000,400,250;1700,1625,250", params), &response);
    ASSERT_TRUE(status.ok()) << params << ": " << status.error_message();
    EXPECT_TRUE(std::isfinite(response.risk())) << params;
    EXPECT_TRUE(std::isfinite(response.length_m())) << params;
    for (const v1::PieceEvaluation& piece : response.pieces()) {
      EXPECT_TRUE(std::isfinite(piece.risk())) << params;
    }
  }
}

// The budget is honoured inside the planner's steps: GENETIC with pieces of
// tens of thousands of samples (a small climb angle, a fine step) still
// answers with its final message.
TEST_F(HardLimitsTest, APlanWithLongEdgesEndsWithItsBudget) {
  v1::PlanRequest r = Plan(100, "sample_step_m=0.5,max_climb_rad=0.01", v1::GENETIC);
  const PlanOutcome plan = RunPlan(*client_, r, absl::Seconds(60));
  ASSERT_TRUE(plan.status.ok()) << plan.status.error_message();
  ASSERT_FALSE(plan.updates.empty());
  EXPECT_TRUE(plan.updates.back().final());
}

// A call whose bytes are not the method's request message: INVALID_ARGUMENT
// naming the message, where gRPC's generated handlers say UNIMPLEMENTED with
// no message.
TEST_F(HardLimitsTest, BytesThatAreNotARequestAreInvalidArgument) {
  grpc::GenericStub stub(client_->channel());
  // Field 0 does not exist, and wire type 7 neither.
  const std::string garbage = "\xff\xff\xff\xff";
  for (const std::string method :
       {"PlanTrajectory", "EvaluateRisk", "ListMaps", "GetMapLayer", "Ping"}) {
    grpc::Slice slice(garbage);
    grpc::ByteBuffer request(&slice, 1);
    grpc::ByteBuffer response;
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
    grpc::CompletionQueue cq;
    auto call = stub.PrepareUnaryCall(&ctx, "/riskplan.v1.Planner/" + method, request, &cq);
    call->StartCall();
    grpc::Status status;
    call->Finish(&response, &status, reinterpret_cast<void*>(1));
    void* tag = nullptr;
    bool ok = false;
    ASSERT_TRUE(cq.Next(&tag, &ok));
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << method;
    EXPECT_EQ(status.error_message(),
              absl::StrFormat("request: the 4 bytes received are not a riskplan.v1.%sRequest "
                              "(protobuf wire format)",
                              method == "PlanTrajectory" ? "Plan" : method))
        << method;
    cq.Shutdown();
    while (cq.Next(&tag, &ok)) {
    }
  }
  EXPECT_TRUE(client_->Ping().ok());
}

// The final message's trajectory, exactly.
struct Trajectory {
  std::vector<std::array<double, 4>> waypoints;
  double risk = 0.0;
  double length_m = 0.0;
  int64_t iterations = 0;
};

Trajectory FinalTrajectory(const PlanOutcome& plan) {
  Trajectory t;
  EXPECT_TRUE(plan.status.ok()) << plan.status.error_message();
  if (plan.updates.empty()) return t;
  const v1::PlanUpdate& last = plan.updates.back();
  EXPECT_TRUE(last.final());
  for (const v1::Pose& p : last.trajectory().waypoints()) {
    t.waypoints.push_back({p.x(), p.y(), p.z(), p.theta()});
  }
  t.risk = last.trajectory().risk();
  t.length_m = last.trajectory().length_m();
  t.iterations = last.iterations();
  return t;
}

// A flood of the adversarial requests, and of valid requests that make the
// server work (fine sampling, model parameters that build a new model), from
// several clients, while a good plan runs: every flood request gets what it
// must, and the plan's final trajectory is bit for bit the one it has alone.
TEST_F(HardLimitsTest, AFloodBesideAGoodPlanLeavesItBitIdentical) {
  const v1::PlanRequest good = SmallCityPlan(0, /*iterations=*/1500);
  const Trajectory alone = FinalTrajectory(RunPlan(*client_, good, absl::Seconds(120)));
  ASSERT_FALSE(alone.waypoints.empty());

  const std::vector<AdversarialEval> evals = AdversarialEvals();
  const std::vector<AdversarialPlan> plans = AdversarialPlans();
  std::atomic<bool> done{false};
  std::mutex mu;
  std::vector<std::string> failures;
  std::atomic<int> sent{0};
  std::vector<std::thread> flood;
  for (int t = 0; t < 3; ++t) {
    flood.emplace_back([&, t] {
      client::RiskplanClient client(server_->Channel());
      for (int k = t; !done.load() || k < t + 12; ++k) {
        std::string failure;
        switch (k % 4) {
          case 0:
          case 1: {
            const AdversarialEval& c = evals[k % evals.size()];
            v1::EvaluateRiskResponse response;
            failure =
                Mismatch(client.EvaluateRisk(c.request, &response, absl::Seconds(60)), c.expected);
            if (!failure.empty()) failure = c.what + ": " + failure;
            break;
          }
          case 2: {
            const AdversarialPlan& c = plans[k % plans.size()];
            failure = Mismatch(RunPlan(client, c.request, absl::Seconds(60)).status, c.expected);
            if (!failure.empty()) failure = c.what + ": " + failure;
            break;
          }
          default: {
            // Valid work: a fine evaluation, with a model of its own.
            v1::EvaluateRiskResponse response;
            const grpc::Status s = client.EvaluateRisk(
                Eval("300,375,240;1000,400,250;1700,1625,250",
                     absl::StrFormat("sample_step_m=0.1,mass_kg=%d", 9 + k % 3)),
                &response, absl::Seconds(60));
            if (!s.ok() || !std::isfinite(response.risk())) {
              failure = "valid evaluation: " + s.error_message();
            }
          }
        }
        ++sent;
        if (!failure.empty()) {
          std::lock_guard<std::mutex> lock(mu);
          failures.push_back(failure);
        }
      }
    });
  }
  const Trajectory flooded = FinalTrajectory(RunPlan(*client_, good, absl::Seconds(120)));
  done.store(true);
  for (std::thread& t : flood) t.join();
  EXPECT_THAT(failures, ::testing::IsEmpty());
  EXPECT_GE(sent.load(), 36);

  ASSERT_EQ(flooded.waypoints.size(), alone.waypoints.size());
  for (size_t k = 0; k < alone.waypoints.size(); ++k) {
    for (int c = 0; c < 4; ++c) EXPECT_EQ(flooded.waypoints[k][c], alone.waypoints[k][c]) << k;
  }
  EXPECT_EQ(flooded.risk, alone.risk);
  EXPECT_EQ(flooded.length_m, alone.length_m);
  EXPECT_EQ(flooded.iterations, alone.iterations);
}

// About 56 million samples (4,000 legs of 1.4 km every 0.1 m): tens of seconds
// of work each, so that eight of them on one worker outlast a 3 s grace period
// on any machine by a wide margin (the server is started with a sample limit
// that admits them).
v1::EvaluateRiskRequest HeavyEval() {
  std::string points;
  for (int i = 0; i < 4000; ++i) {
    absl::StrAppendFormat(&points, "%s%d,%d,250", i == 0 ? "" : ";", i % 2 == 0 ? 300 : 1700,
                          400 + 5 * (i % 200));
  }
  return Eval(points, "sample_step_m=0.1");
}

// SIGTERM with long evaluations queued and running and a long plan: the plan
// ends with SHUTDOWN, the evaluations are stopped (UNAVAILABLE) or done, and
// the server exits 0 within its grace period (its last-resort exit after the
// grace period would be code 1).
TEST(HardLimitsShutdownTest, DrainEndsLongWorkInFlight) {
  auto started = ServerProcess::Start(
      {"--grace_period_ms=3000", "--eval_threads=1", "--max_eval_samples=100000000"});
  ASSERT_TRUE(started.ok()) << started.status();
  std::unique_ptr<ServerProcess> server = *std::move(started);
  const ServerProcess& target = *server;

  // The evaluations are sent first, then the plan; the signal comes once
  // the plan has streamed (it runs) and every evaluation is on its way.
  absl::Mutex mu;
  int evals_started = 0;
  bool plan_running = false;
  std::vector<grpc::Status> eval_status(8);
  std::vector<std::thread> evals;
  for (size_t i = 0; i < eval_status.size(); ++i) {
    evals.emplace_back([&, i] {
      client::RiskplanClient client(target.Channel());
      v1::EvaluateRiskResponse response;
      {
        absl::MutexLock lock(&mu);
        ++evals_started;
      }
      eval_status[i] = client.EvaluateRisk(HeavyEval(), &response, absl::Seconds(120));
    });
  }
  client::RiskplanClient client(target.Channel());
  PlanOutcome plan;
  std::thread planner([&] {
    plan.status = client.Plan(
        SmallCityPlan(60000),
        [&](const v1::PlanUpdate& u) {
          plan.updates.push_back(u);
          absl::MutexLock lock(&mu);
          plan_running = true;
          return true;
        },
        absl::Seconds(120));
  });
  {
    absl::MutexLock lock(&mu);
    const auto ready = [&]() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu) {
      return plan_running && evals_started == static_cast<int>(eval_status.size());
    };
    mu.Await(absl::Condition(&ready));
  }
  server->Signal(SIGTERM);
  const std::optional<int> exit_code = server->Wait(absl::Seconds(60));
  planner.join();
  for (std::thread& t : evals) t.join();
  ASSERT_TRUE(exit_code.has_value());
  EXPECT_EQ(*exit_code, 0) << server->Stderr();
  const std::string log = server->Stderr();
  EXPECT_THAT(log, ::testing::Not(HasSubstr("drain_timeout")));
  ASSERT_TRUE(plan.status.ok()) << plan.status.error_message();
  ASSERT_FALSE(plan.updates.empty());
  EXPECT_EQ(plan.updates.back().end_reason(), v1::SHUTDOWN);
  int stopped = 0;
  for (const grpc::Status& s : eval_status) {
    EXPECT_TRUE(s.ok() || s.error_code() == grpc::StatusCode::UNAVAILABLE ||
                s.error_code() == grpc::StatusCode::CANCELLED)
        << client::StatusCodeName(s.error_code()) << ": " << s.error_message();
    if (s.error_code() == grpc::StatusCode::UNAVAILABLE) ++stopped;
  }
  // Eight evaluations of tens of seconds each on one worker cannot all be
  // done within the 3 s grace period: the drain stopped some.
  EXPECT_GE(stopped, 1);
}

// GetMapLayer waits in the evaluation queue too: when the queue is full it
// is refused as EvaluateRisk is, naming the flag that sets the limit.
TEST(EvaluationQueueTest, AFullQueueNamesTheFlagForGetMapLayer) {
  absl::StatusOr<std::unique_ptr<ServerProcess>> server =
      ServerProcess::Start({"--eval_threads=1", "--max_queued_evals=1"});
  ASSERT_TRUE(server.ok()) << server.status();
  client::RiskplanClient client((*server)->address());
  v1::GetMapLayerRequest layer;
  layer.set_map("demo-city");
  layer.set_layer(v1::POPULATION_DENSITY);
  layer.set_max_side_cells(4096);
  std::mutex mu;
  std::vector<grpc::Status> refused;
  const absl::Time deadline = absl::Now() + absl::Seconds(60);
  while (refused.empty() && absl::Now() < deadline) {
    std::vector<std::thread> callers;
    for (int i = 0; i < 16; ++i) {
      callers.emplace_back([&] {
        v1::GetMapLayerResponse response;
        const grpc::Status status = client.GetMapLayer(layer, &response);
        if (status.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED) {
          std::lock_guard<std::mutex> lock(mu);
          refused.push_back(status);
        }
      });
    }
    for (std::thread& t : callers) t.join();
  }
  ASSERT_FALSE(refused.empty()) << "the queue of one never filled";
  EXPECT_EQ(refused[0].error_message(),
            "riskplan-server has 1 evaluations waiting (--max_queued_evals); retry later");
}

}  // namespace
}  // namespace riskplan::testing
