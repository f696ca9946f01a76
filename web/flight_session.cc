#include "web/flight_session.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/time/clock.h"
#include "client/client.h"
#include "nlohmann/json.hpp"
#include "web/plan_session.h"
#include "web/proto_json.h"

namespace riskplan::web {
namespace {

using Json = nlohmann::json;

std::string GatewayMs() { return absl::StrFormat("%.3f", EpochMs()); }

// Where the aircraft is after `s` m along `route`'s display path (its
// samples every display step of 3-D arc length, joined by straight lines):
// the position event's fields, with WGS84 when the route has it.
Json PoseAlong(const v1::Trajectory& route, double s) {
  Json out = Json::object();
  const int n = route.path_size();
  if (n == 0) return out;
  const bool wgs84 = route.path_wgs84_size() == n;
  double walked = 0.0;
  int k = 0;
  double f = 0.0;
  for (k = 0; k + 1 < n; ++k) {
    const v1::Pose& a = route.path(k);
    const v1::Pose& b = route.path(k + 1);
    const double d = std::hypot(b.x() - a.x(), b.y() - a.y(), b.z() - a.z());
    if (walked + d >= s) {
      f = d > 0.0 ? (s - walked) / d : 0.0;
      break;
    }
    walked += d;
  }
  if (k + 1 >= n) {
    k = n - 1;
    f = 0.0;
  }
  const int j = std::min(k + 1, n - 1);
  const auto mix = [f](double a, double b) { return a + f * (b - a); };
  const v1::Pose& a = route.path(k);
  const v1::Pose& b = route.path(j);
  out["x"] = mix(a.x(), b.x());
  out["y"] = mix(a.y(), b.y());
  out["z"] = mix(a.z(), b.z());
  if (wgs84) {
    out["lat_deg"] = mix(route.path_wgs84(k).lat_deg(), route.path_wgs84(j).lat_deg());
    out["lon_deg"] = mix(route.path_wgs84(k).lon_deg(), route.path_wgs84(j).lon_deg());
  }
  return out;
}

}  // namespace

FlightSession::FlightSession(std::string id, v1::FlightOpen open, double speedup,
                             FlightGatewayLimits limits)
    : id_(std::move(id)),
      open_(std::move(open)),
      speedup_(speedup),
      limits_(limits),
      events_(limits.events),
      tokens_(limits.max_changes_per_s),
      tokens_at_(absl::Now()) {
  for (const v1::FlightZone& z : open_.zones()) zones_.insert(z.id());
}

FlightSession::~FlightSession() {
  Stop();
  if (thread_.joinable()) thread_.join();
  link_.reset();  // joins the link's reader, which appends to events_
}

void FlightSession::Start(std::shared_ptr<grpc::Channel> channel) {
  thread_ = std::thread([this, channel = std::move(channel)] { Run(channel); });
}

void FlightSession::AppendJson(const std::string& type, const std::string& fields, bool terminal) {
  events_.Append(type, absl::StrCat("{\"gateway_ms\":", GatewayMs(), fields, "}"), terminal);
}

void FlightSession::OnOutput(const v1::FlightOutput& out) {
  {
    // Before the event is seen: a page that saw a version may send zones.
    absl::MutexLock lock(&mu_);
    if (out.has_plan()) {
      alert_in_force_ = false;
      opened_ = true;
    }
    if (out.has_alert()) alert_in_force_ = true;
  }
  if (out.has_plan()) {
    v1::FlightPlanVersion v = out.plan();
    RoundDisplayPath(v.mutable_route());
    RoundDisplayPath(v.mutable_remainder());
    AppendJson("version", absl::StrCat(",\"version\":", ToJson(v)), false);
  } else if (out.has_alert()) {
    AppendJson("alert", absl::StrCat(",\"alert\":", ToJson(out.alert())), false);
  } else if (out.has_refusal()) {
    AppendJson("refusal", absl::StrCat(",\"refusal\":", ToJson(out.refusal())), false);
  }
}

bool FlightSession::Wait(absl::Duration d) {
  absl::MutexLock lock(&mu_);
  auto over = [this]() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) { return end_requested_ || stopped_; };
  mu_.AwaitWithTimeout(absl::Condition(&over), d);
  return !over();
}

void FlightSession::Run(std::shared_ptr<grpc::Channel> channel) {
  auto fail = [this](const grpc::Status& s, const std::string& prefix) {
    {
      absl::MutexLock lock(&mu_);
      failed_ = true;
    }
    AppendJson(
        "failed",
        absl::StrCat(
            ",\"code\":", Json(client::StatusCodeName(s.error_code())).dump(), ",\"message\":",
            Json(prefix + s.error_message()).dump(-1, ' ', false, Json::error_handler_t::replace)),
        true);
  };
  link_ = std::make_unique<client::FlightLink>(
      channel, open_, [this](int, const v1::FlightOutput& out) { OnOutput(out); },
      [this](int stream, const grpc::Status& why) {
        AppendJson("resumed",
                   absl::StrCat(",\"message\":",
                                Json(absl::StrFormat("the flight's stream broke (%s: %s); resumed "
                                                     "on stream %d",
                                                     client::StatusCodeName(why.error_code()),
                                                     why.error_message(), stream))
                                    .dump(-1, ' ', false, Json::error_handler_t::replace)),
                   false);
      });
  if (grpc::Status s = link_->Open(); !s.ok()) return fail(s, "");

  // The first version, before the aircraft moves; a refused opening ends
  // the stream with the server's words.
  const absl::Time give_up = absl::Now() + limits_.first_version_timeout;
  while (!link_->latest().has_value()) {
    if (std::optional<grpc::Status> s = link_->ended_status(); s.has_value()) {
      return fail(s->ok() ? grpc::Status(grpc::StatusCode::UNAVAILABLE,
                                         "the server ended the flight before its first plan")
                          : *s,
                  "");
    }
    if (absl::Now() > give_up) {
      link_->Break();
      return fail(
          grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED,
                       absl::StrFormat("no plan version within %d s",
                                       absl::ToInt64Seconds(limits_.first_version_timeout))),
          "");
    }
    if (!Wait(absl::Milliseconds(20))) break;
  }
  const double t0 = open_.time_s();
  double t = t0;
  double progress = open_.progress_m();
  const double dt = speedup_ * absl::ToDoubleSeconds(limits_.report_every);
  std::string why = "ended from the page";
  while (true) {
    const std::optional<v1::FlightPlanVersion> v = link_->latest();
    if (!v.has_value()) break;
    const double total = v->committed_until_m() + v->remainder().length_m();
    const double speed =
        v->route().flight_time_s() > 0.0 ? v->route().length_m() / v->route().flight_time_s() : 0.0;
    bool alert;
    {
      absl::MutexLock lock(&mu_);
      alert = alert_in_force_;
    }
    // With an alert in force the remainder is not to be flown: the
    // aircraft goes no further than the commit point (a real one would
    // divert to the alert's landing site) until a new version comes.
    const double reach = alert ? std::min(total, v->committed_until_m()) : total;
    if (!alert && progress >= total - 1e-6) {
      why = "the aircraft reached the goal";
      break;
    }
    if (t - t0 >= limits_.max_flight_time_s) {
      why = absl::StrFormat("the flight reached this gateway's bound of %g s of flight time",
                            limits_.max_flight_time_s);
      break;
    }
    if (!Wait(limits_.report_every)) break;
    t += dt;
    progress = std::max(progress, std::min(reach, progress + speed * dt));
    v1::FlightInput report;
    report.mutable_position()->set_time_s(t);
    report.mutable_position()->set_progress_m(progress);
    if (grpc::Status s = link_->Send(report); !s.ok()) return fail(s, "");
    Json fields = PoseAlong(v->route(), progress);
    fields["time_s"] = t;
    fields["progress_m"] = progress;
    std::string text = fields.dump();
    text.front() = ',';  // the fields after gateway_ms
    text.pop_back();
    AppendJson("position", text, false);
  }
  bool stopped;
  {
    absl::MutexLock lock(&mu_);
    stopped = stopped_;
  }
  if (stopped) {
    link_->Break();
    return;
  }
  const grpc::Status end = link_->End();
  if (!end.ok() && end.error_code() != grpc::StatusCode::CANCELLED) return fail(end, "");
  AppendJson("ended",
             absl::StrCat(",\"message\":", Json(why).dump(), ",\"time_s\":", Json(t).dump(),
                          ",\"progress_m\":", Json(progress).dump()),
             true);
}

absl::Status FlightSession::Input(const v1::FlightInput& input) {
  if (input.kind_case() != v1::FlightInput::kAddZone &&
      input.kind_case() != v1::FlightInput::kRemoveZone &&
      input.kind_case() != v1::FlightInput::kWind) {
    return absl::InvalidArgumentError(
        "input: the page sends add_zone, remove_zone or wind; the gateway itself sends open, "
        "position and end");
  }
  {
    absl::MutexLock lock(&mu_);
    if (events_.ended() || end_requested_ || stopped_) {
      return absl::FailedPreconditionError(absl::StrFormat("flight '%s' has ended", id_));
    }
    if (!opened_) {
      return absl::FailedPreconditionError(
          "the flight has no plan version yet; send zones once the first has come");
    }
    const absl::Time now = absl::Now();
    tokens_ =
        std::min(limits_.max_changes_per_s,
                 tokens_ + limits_.max_changes_per_s * absl::ToDoubleSeconds(now - tokens_at_));
    tokens_at_ = now;
    if (tokens_ < 1.0) {
      return absl::ResourceExhaustedError(absl::StrFormat(
          "this gateway takes at most %g zone or wind changes a second on one flight; try again "
          "in a moment",
          limits_.max_changes_per_s));
    }
    if (input.has_add_zone() && zones_.count(input.add_zone().id()) == 0 &&
        static_cast<int>(zones_.size()) >= limits_.max_zones) {
      return absl::ResourceExhaustedError(absl::StrFormat(
          "this gateway holds at most %d zones on one flight (--max_flight_zones); remove one "
          "first",
          limits_.max_zones));
    }
    tokens_ -= 1.0;
    if (input.has_add_zone()) zones_.insert(input.add_zone().id());
    if (input.has_remove_zone()) zones_.erase(input.remove_zone().id());
  }
  grpc::Status s = link_->Send(input);
  if (!s.ok()) {
    // The flight's stream is gone (its "failed" event follows).
    return absl::UnavailableError(absl::StrFormat("the flight's link to the server failed: %s: %s",
                                                  client::StatusCodeName(s.error_code()),
                                                  s.error_message()));
  }
  return absl::OkStatus();
}

bool FlightSession::End() {
  absl::MutexLock lock(&mu_);
  if (events_.ended() || end_requested_) return false;
  end_requested_ = true;
  return true;
}

void FlightSession::Stop() {
  {
    absl::MutexLock lock(&mu_);
    stopped_ = true;
  }
  events_.Stop();
}

std::string FlightSession::state() const {
  absl::MutexLock lock(&mu_);
  if (failed_) return "failed";
  if (events_.ended()) return "ended";
  return opened_ ? "flying" : "opening";
}

FlightRegistry::~FlightRegistry() { StopAll(); }

absl::StatusOr<std::shared_ptr<FlightSession>> FlightRegistry::Start(
    v1::FlightOpen open, double speedup, std::shared_ptr<grpc::Channel> channel) {
  if (!(speedup >= 1.0 && speedup <= limits_.max_speedup)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "speedup has value %g; it must be in [1, %g] (flight time per second of real time)",
        speedup, limits_.max_speedup));
  }
  if (open.resume() || open.route_size() > 0) {
    return absl::InvalidArgumentError(
        "open.resume and open.route are the link's own (it resumes a broken stream); a flight "
        "from the page starts afresh");
  }
  if (open.zones_size() > limits_.max_zones) {
    return absl::ResourceExhaustedError(absl::StrFormat(
        "open.zones has %d zones; this gateway holds at most %d zones on one flight "
        "(--max_flight_zones)",
        open.zones_size(), limits_.max_zones));
  }
  absl::StatusOr<std::shared_ptr<FlightSession>> session = sessions_.Add(
      limits_.max_running, limits_.max_kept,
      absl::StrFormat("this gateway flies at most %d flights at once (--max_flights); end one or "
                      "wait for one to land",
                      limits_.max_running),
      "f", [&](std::string id) {
        return std::make_shared<FlightSession>(std::move(id), std::move(open), speedup, limits_);
      });
  if (session.ok()) (*session)->Start(std::move(channel));
  return session;
}

}  // namespace riskplan::web
