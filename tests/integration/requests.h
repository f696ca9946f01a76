// Requests on the small demo-city that ServerProcess serves by default.
#ifndef RISKPLAN_TESTS_INTEGRATION_REQUESTS_H_
#define RISKPLAN_TESTS_INTEGRATION_REQUESTS_H_

#include <vector>

#include "client/client.h"
#include "client/trajectory_text.h"
#include "riskplan/v1/planner.pb.h"
#include "tests/integration/server_process.h"

namespace riskplan::testing {

// A plan across the small city with a time budget (and iterations if > 0).
inline v1::PlanRequest SmallCityPlan(int64_t time_ms, int64_t iterations = 0) {
  v1::PlanRequest r;
  r.set_map("demo-city");
  *r.mutable_start() = *client::ParsePose(kSmallCityStart);
  *r.mutable_goal() = *client::ParsePose(kSmallCityGoal);
  r.mutable_budget()->set_time_ms(time_ms);
  r.mutable_budget()->set_iterations(iterations);
  r.set_seed(7);
  return r;
}

// A straight polyline across the small city at 250 m AMSL.
inline v1::EvaluateRiskRequest SmallCityPolyline() {
  v1::EvaluateRiskRequest r;
  r.set_map("demo-city");
  *r.mutable_polyline() = *client::ParsePolyline("300,375,240; 1000,400,250; 1700,1625,250");
  return r;
}

// Every update of a plan, and the call's status.
struct PlanOutcome {
  grpc::Status status;
  std::vector<v1::PlanUpdate> updates;
};

inline PlanOutcome RunPlan(client::RiskplanClient& client, const v1::PlanRequest& request,
                           absl::Duration timeout = absl::InfiniteDuration()) {
  PlanOutcome outcome;
  outcome.status = client.Plan(
      request,
      [&](const v1::PlanUpdate& u) {
        outcome.updates.push_back(u);
        return true;
      },
      timeout);
  return outcome;
}

}  // namespace riskplan::testing

#endif  // RISKPLAN_TESTS_INTEGRATION_REQUESTS_H_
