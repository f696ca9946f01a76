// `riskplan fly --scenario=FILE.json`: a scripted flight on a Fly session
// (docs/in-flight.md). The aircraft follows the latest plan version at its
// mean ground speed (the route's length over its flight time), reporting its
// progress every `report_interval_s` of flight time, `speedup` times faster
// than real time; at their times the scenario's events are sent (zones,
// wind) or the stream is broken (the link resumes on a replica of
// --server). Every plan version, alert and refusal is printed as it comes.
//
// FILE.json:
//   {"open": FlightOpen (protobuf JSON: {"plan": {"map": ..., "start": {...},
//            "goal": {...}, "budget": {"timeMs": 1000}}, "commitHorizonS": 10, ...}),
//    "speedup": 10, "report_interval_s": 1, "max_time_s": 3600,
//    "events": [{"at_s": 20, "input": FlightInput (protobuf JSON, e.g.
//                {"addZone": {"id": "fire", "circle": {"x": 900, "y": 900, "radiusM": 150}}})},
//               {"at_s": 40, "break": true}, ...]}
#include <algorithm>
#include <atomic>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/clock.h"
#include "client/cli/command_support.h"
#include "client/cli/commands.h"
#include "client/flight_link.h"
#include "google/protobuf/util/json_util.h"
#include "nlohmann/json.hpp"

namespace riskplan::client {
namespace {

struct ScenarioEvent {
  double at_s = 0.0;
  bool brk = false;
  v1::FlightInput input;
};

struct Scenario {
  v1::FlightOpen open;
  double speedup = 10.0;
  double report_interval_s = 1.0;
  double max_time_s = 3600.0;
  std::vector<ScenarioEvent> events;
};

absl::StatusOr<Scenario> ReadScenario(const std::string& path) {
  std::ifstream file(path);
  if (!file) return absl::NotFoundError(absl::StrFormat("--scenario: cannot read '%s'", path));
  std::stringstream text;
  text << file.rdbuf();
  nlohmann::json j = nlohmann::json::parse(text.str(), nullptr, false);
  if (j.is_discarded() || !j.is_object()) {
    return absl::InvalidArgumentError(absl::StrFormat("--scenario: '%s' is not a JSON object", path));
  }
  Scenario s;
  if (!j.contains("open")) {
    return absl::InvalidArgumentError("--scenario: no \"open\" (the FlightOpen of the session)");
  }
  if (auto st = google::protobuf::util::JsonStringToMessage(j["open"].dump(), &s.open); !st.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("--scenario: \"open\": ", std::string(st.message())));
  }
  const auto number = [&](const char* key, double* out, double min, double max) -> absl::Status {
    if (!j.contains(key)) return absl::OkStatus();
    if (!j[key].is_number() || !(j[key].get<double>() >= min && j[key].get<double>() <= max)) {
      return absl::InvalidArgumentError(
          absl::StrFormat("--scenario: \"%s\" must be a number in [%g, %g]", key, min, max));
    }
    *out = j[key].get<double>();
    return absl::OkStatus();
  };
  if (auto st = number("speedup", &s.speedup, 0.01, 10000.0); !st.ok()) return st;
  if (auto st = number("report_interval_s", &s.report_interval_s, 0.05, 600.0); !st.ok()) return st;
  if (auto st = number("max_time_s", &s.max_time_s, 1.0, 86400.0); !st.ok()) return st;
  if (j.contains("events")) {
    if (!j["events"].is_array()) return absl::InvalidArgumentError("--scenario: \"events\" must be a list");
    for (size_t k = 0; k < j["events"].size(); ++k) {
      const nlohmann::json& e = j["events"][k];
      ScenarioEvent ev;
      if (!e.is_object() || !e.contains("at_s") || !e["at_s"].is_number() || e["at_s"].get<double>() < 0) {
        return absl::InvalidArgumentError(
            absl::StrFormat("--scenario: events[%d] needs \"at_s\", a flight time >= 0", k));
      }
      ev.at_s = e["at_s"].get<double>();
      if (e.contains("break")) {
        ev.brk = true;
      } else if (e.contains("input")) {
        if (auto st = google::protobuf::util::JsonStringToMessage(e["input"].dump(), &ev.input);
            !st.ok()) {
          return absl::InvalidArgumentError(absl::StrFormat("--scenario: events[%d].input: %s", k,
                                                            std::string(st.message())));
        }
      } else {
        return absl::InvalidArgumentError(
            absl::StrFormat("--scenario: events[%d] needs \"input\" or \"break\"", k));
      }
      s.events.push_back(std::move(ev));
    }
  }
  std::stable_sort(s.events.begin(), s.events.end(),
                   [](const ScenarioEvent& a, const ScenarioEvent& b) { return a.at_s < b.at_s; });
  return s;
}

std::string ReasonName(v1::FlightReason r) {
  std::string name = v1::FlightReason_Name(r);
  return name.substr(std::string("FLIGHT_REASON_").size());
}

void Print(int stream, const v1::FlightOutput& o, absl::Mutex* print_mu) {
  absl::MutexLock lock(print_mu);
  if (o.has_plan()) {
    const v1::FlightPlanVersion& v = o.plan();
    std::printf(
        "[s%d] version %llu %-12s t=%7.1f s progress=%7.1f m committed to %7.1f m  remainder "
        "%6.0f m, %5.1f s  route risk %.6g, %.1f s  zones [%s]  %.1f ms\n",
        stream, static_cast<unsigned long long>(v.version()), ReasonName(v.reason()).c_str(),
        v.time_s(), v.progress_m(), v.committed_until_m(), v.remainder().length_m(),
        v.remainder().flight_time_s(), v.route().risk(), v.route().flight_time_s(),
        absl::StrJoin(v.active_zones(), ",").c_str(), v.planning_ms());
  } else if (o.has_alert()) {
    const v1::FlightAlert& a = o.alert();
    std::printf("[s%d] ALERT %s t=%.1f s: %s\n", stream,
                v1::FlightAlertKind_Name(a.kind()).c_str(), a.time_s(), a.detail().c_str());
    if (a.has_landing()) {
      const v1::EmergencyLanding& l = a.landing();
      std::printf("      emergency landing '%s' at (%.0f, %.0f), glide %.0f m, %.1f m to spare\n",
                  l.site().c_str(), l.site_pose().x(), l.site_pose().y(), l.glide_distance_m(),
                  l.altitude_margin_m());
    }
  } else if (o.has_refusal()) {
    std::printf("[s%d] refused input %llu (%s): %s\n", stream,
                static_cast<unsigned long long>(o.refusal().input()), o.refusal().field().c_str(),
                o.refusal().message().c_str());
  }
  std::fflush(stdout);
}

}  // namespace

int RunFly(const CliOptions& o, RiskplanClient& client) {
  if (o.scenario.empty()) return Usage("fly needs --scenario=FILE.json");
  absl::StatusOr<Scenario> scenario = ReadScenario(o.scenario);
  if (!scenario.ok()) return Usage(std::string(scenario.status().message()));
  absl::Mutex print_mu;
  std::atomic<bool> alert_in_force{false};
  FlightLink link(
      client.channel(), scenario->open,
      [&](int stream, const v1::FlightOutput& out) {
        if (out.has_alert()) alert_in_force = true;
        if (out.has_plan()) alert_in_force = false;
        Print(stream, out, &print_mu);
      },
      [&](int stream, const grpc::Status& why) {
        absl::MutexLock lock(&print_mu);
        std::printf("[s%d] stream broke (%s: %s); resuming\n", stream - 1,
                    StatusCodeName(why.error_code()).c_str(), why.error_message().c_str());
        std::fflush(stdout);
      },
      FlightLinkOptions{.max_reconnects = std::max(1, o.max_resubmits)});
  if (grpc::Status s = link.Open(); !s.ok()) {
    return RpcError(o, "Fly", s);
  }
  // The first version, before the aircraft moves.
  const absl::Time wait_until = absl::Now() + absl::Seconds(60);
  while (!link.latest().has_value() && absl::Now() < wait_until) absl::SleepFor(absl::Milliseconds(5));
  double t = scenario->open.time_s();
  double progress = scenario->open.progress_m();
  size_t next_event = 0;
  const double end_t = t + scenario->max_time_s;
  while (t < end_t) {
    const std::optional<v1::FlightPlanVersion> v = link.latest();
    double total = 0.0, speed = 0.0;
    if (v.has_value()) {
      total = v->committed_until_m() + v->remainder().length_m();
      speed = v->route().flight_time_s() > 0.0 ? v->route().length_m() / v->route().flight_time_s()
                                               : 0.0;
    }
    if (v.has_value() && progress >= total - 1e-6) break;  // at the goal
    t += scenario->report_interval_s;
    progress = std::min(total, progress + speed * scenario->report_interval_s);
    absl::SleepFor(absl::Seconds(scenario->report_interval_s / scenario->speedup));
    while (next_event < scenario->events.size() && scenario->events[next_event].at_s <= t) {
      const ScenarioEvent& e = scenario->events[next_event++];
      if (e.brk) {
        link.Break();
        continue;
      }
      if (grpc::Status s = link.Send(e.input); !s.ok()) {
        return RpcError(o, "Fly", s);
      }
    }
    v1::FlightInput report;
    report.mutable_position()->set_time_s(t);
    report.mutable_position()->set_progress_m(progress);
    if (grpc::Status s = link.Send(report); !s.ok()) {
      return RpcError(o, "Fly", s);
    }
  }
  grpc::Status end = link.End();
  const int streams = link.streams();  // not under print_mu: the link calls back under its own
  {
    absl::MutexLock lock(&print_mu);
    std::printf("flight ended at t=%.1f s, progress %.1f m, %d stream(s): %s\n", t, progress,
                streams, StatusCodeName(end.error_code()).c_str());
  }
  if (!end.ok()) {
    return RpcError(o, "Fly", end);
  }
  return alert_in_force.load() ? 3 : 0;
}

}  // namespace riskplan::client
