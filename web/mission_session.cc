// PlanSession::RunMission: a QGroundControl mission planned leg by leg
// (web/plan_session.h, MissionPlan, says what the viewers receive).
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/client.h"
#include "client/mission.h"
#include "nlohmann/json.hpp"
#include "web/plan_session.h"
#include "web/proto_json.h"

namespace riskplan::web {
namespace {

using Json = nlohmann::json;

constexpr absl::Duration kEvaluateTimeout = absl::Seconds(60);

bool AnyLimit(const v1::FlightLimits& l) {
  return l.max_flight_time_s() > 0 || l.max_length_m() > 0 || l.max_risk() > 0 ||
         l.max_risk_per_flight_hour() > 0 || l.objective() == v1::MIN_TIME;
}

std::string Stamped(const v1::PlanUpdate& update, const Json& extra) {
  Json head = extra;
  std::string data = absl::StrCat("{\"gateway_ms\":", absl::StrFormat("%.3f", EpochMs()));
  for (auto it = head.begin(); it != head.end(); ++it) {
    absl::StrAppend(&data, ",", Json(it.key()).dump(), ":", it.value().dump());
  }
  absl::StrAppend(&data, ",\"update\":", ToJson(update), "}");
  return data;
}

// Appends `from` to `to`, the first element dropped when `to` already ends
// where `from` begins (the legs share their mission points).
template <typename Field>
void Join(const Field& from, Field* to) {
  for (int k = to->empty() ? 0 : 1; k < from.size(); ++k) *to->Add() = from[k];
}

}  // namespace

void PlanSession::RunMission(v1::Planner::Stub* stub) {
  const WebMission& mission = *mission_->mission;
  const v1::FlightLimits& whole = mission_->whole;
  const size_t n = mission.legs.size();
  auto failed = [this](const std::string& code, const std::string& message) {
    Append("failed",
           Json{{"code", code}, {"message", message}}.dump(-1, ' ', false,
                                                           Json::error_handler_t::replace),
           PlanState::kFailed);
  };
  auto leg_request = [&](size_t i) {
    v1::PlanRequest r = request_;
    *r.mutable_start_wgs84() = mission.legs[i].start;
    *r.mutable_goal_wgs84() = mission.legs[i].goal;
    r.clear_limits();
    return r;
  };

  // Every leg's ends checked by the server before any leg is planned (one
  // iteration each), so that a point off the map or not admissible is
  // refused at once, naming its mission item.
  for (size_t i = 0; i < n; ++i) {
    v1::PlanRequest check = leg_request(i);
    check.mutable_budget()->set_time_ms(0);
    check.mutable_budget()->set_iterations(1);
    check.set_min_update_interval_ms(0);
    std::shared_ptr<grpc::ClientContext> context = NewCall();
    if (context == nullptr) return EndBeforeCall();
    auto reader = stub->PlanTrajectory(context.get(), check);
    v1::PlanUpdate ignored;
    while (reader->Read(&ignored)) {
    }
    const grpc::Status s = reader->Finish();
    if (s.ok()) continue;
    if (EndIfCancelled(s)) return;
    if (s.error_code() == grpc::StatusCode::INVALID_ARGUMENT) {
      return failed("INVALID_ARGUMENT", LegEndpointError(mission, i, s.error_message()));
    }
    return failed(client::StatusCodeName(s.error_code()),
                  absl::StrCat(LegName(mission, i), ": ", s.error_message()));
  }

  client::MissionUsed used;
  double elapsed_before = 0.0;
  int64_t iterations_before = 0, improvements_before = 0;
  uint64_t configurations = 0;
  std::vector<v1::Trajectory> finals;
  v1::PlanUpdate last_final;
  for (size_t i = 0; i < n; ++i) {
    v1::PlanRequest request = leg_request(i);
    if (AnyLimit(whole)) {
      *request.mutable_limits() = client::LegLimits(whole, used, mission.mission, mission.legs, i);
    }
    std::shared_ptr<grpc::ClientContext> context = NewCall();
    if (context == nullptr) return EndBeforeCall();
    auto reader = stub->PlanTrajectory(context.get(), request);
    v1::PlanUpdate update;
    v1::PlanUpdate final_update;
    bool got_final = false;
    while (reader->Read(&update)) {
      update.set_elapsed_s(update.elapsed_s() + elapsed_before);
      update.set_iterations(update.iterations() + iterations_before);
      update.set_improvements(update.improvements() + improvements_before);
      if (update.has_trajectory()) RoundDisplayPath(update.mutable_trajectory());
      for (v1::Trajectory& t : *update.mutable_front()) RoundDisplayPath(&t);
      if (update.final()) {
        got_final = true;
        final_update = update;
      }
      Append("update", Stamped(update, Json{{"leg", i}, {"legs", n}}), PlanState::kRunning);
    }
    const grpc::Status s = reader->Finish();
    if (!s.ok() || !got_final) {
      if (EndIfCancelled(s)) return;
      return failed(client::StatusCodeName(s.error_code()),
                    absl::StrCat(LegName(mission, i), ": ", s.error_message()));
    }
    elapsed_before = final_update.elapsed_s();
    iterations_before = final_update.iterations();
    improvements_before = final_update.improvements();
    configurations += final_update.configurations_evaluated();
    if (!final_update.has_trajectory()) {
      // Nothing within this leg's share of the limits: the mission ends here.
      v1::PlanUpdate end;
      end.set_final(true);
      end.set_end_reason(final_update.end_reason());
      end.set_elapsed_s(final_update.elapsed_s());
      end.set_iterations(final_update.iterations());
      end.set_improvements(final_update.improvements());
      end.set_configurations_evaluated(configurations);
      *end.mutable_wind() = final_update.wind();
      *end.mutable_limits() = final_update.limits();
      const std::string why = final_update.limits().note().empty()
                                  ? std::string("no admissible trajectory was found")
                                  : final_update.limits().note();
      end.mutable_limits()->set_note(absl::StrCat(
          LegName(mission, i), " cannot be flown within the limits left to it: ", why));
      Append("final", Stamped(end, Json{{"mission", {{"legs", n}, {"failed_leg", i}}}}),
             PlanState::kFinished);
      return;
    }
    const v1::Trajectory& t = final_update.trajectory();
    used.flight_time_s += t.flight_time_s();
    used.length_m += t.length_m();
    used.risk += t.risk();
    finals.push_back(t);
    last_final = std::move(final_update);
  }

  // The mission: every leg joined, its totals from one evaluation of all
  // the waypoints (as `riskplan plan --mission` gives them).
  v1::Trajectory joined;
  std::vector<size_t> leg_ends;
  bool wgs84 = true;
  for (const v1::Trajectory& t : finals) {
    Join(t.waypoints(), joined.mutable_waypoints());
    Join(t.path(), joined.mutable_path());
    wgs84 = wgs84 && t.waypoints_wgs84_size() == t.waypoints_size() &&
            t.path_wgs84_size() == t.path_size();
    if (wgs84) {
      Join(t.waypoints_wgs84(), joined.mutable_waypoints_wgs84());
      Join(t.path_wgs84(), joined.mutable_path_wgs84());
    }
    leg_ends.push_back(static_cast<size_t>(joined.waypoints_size() - 1));
  }
  if (!wgs84) {
    joined.clear_waypoints_wgs84();
    joined.clear_path_wgs84();
  }
  v1::EvaluateRiskRequest eval;
  eval.set_map(request_.map());
  *eval.mutable_model_params() = request_.model_params();
  if (request_.has_wind()) *eval.mutable_wind() = request_.wind();
  if (request_.has_wind_wgs84()) *eval.mutable_wind_wgs84() = request_.wind_wgs84();
  *eval.mutable_waypoints()->mutable_poses() = joined.waypoints();
  std::shared_ptr<grpc::ClientContext> context = NewCall();
  if (context == nullptr) return EndBeforeCall();
  context->set_deadline(std::chrono::system_clock::now() +
                        absl::ToChronoMilliseconds(kEvaluateTimeout));
  v1::EvaluateRiskResponse total;
  const grpc::Status s = stub->EvaluateRisk(context.get(), eval, &total);
  if (!s.ok()) {
    if (EndIfCancelled(s)) return;
    return failed(client::StatusCodeName(s.error_code()),
                  absl::StrCat("the whole mission's evaluation: ", s.error_message()));
  }
  joined.set_risk(total.risk());
  joined.set_length_m(total.length_m());
  joined.set_flight_time_s(total.flight_time_s());
  joined.set_risk_per_flight_hour(total.risk_per_flight_hour());
  joined.set_found_at_iteration(last_final.iterations());
  joined.set_found_at_s(last_final.elapsed_s());

  v1::PlanUpdate end;
  end.set_final(true);
  end.set_end_reason(last_final.end_reason());
  end.set_elapsed_s(last_final.elapsed_s());
  end.set_iterations(last_final.iterations());
  end.set_improvements(last_final.improvements());
  end.set_configurations_evaluated(configurations);
  *end.mutable_wind() = last_final.wind();
  *end.mutable_trajectory() = std::move(joined);
  Append("final", Stamped(end, Json{{"mission", {{"legs", n}, {"leg_ends", leg_ends}}}}),
         PlanState::kFinished);
}

}  // namespace riskplan::web
