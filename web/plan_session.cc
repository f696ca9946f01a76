#include "web/plan_session.h"

#include <cmath>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/time/clock.h"
#include "client/client.h"
#include "nlohmann/json.hpp"
#include "web/proto_json.h"

namespace riskplan::web {

double EpochMs() { return absl::ToDoubleMilliseconds(absl::Now() - absl::UnixEpoch()); }

const char* PlanStateName(PlanState state) {
  switch (state) {
    case PlanState::kRunning:
      return "running";
    case PlanState::kFinished:
      return "finished";
    case PlanState::kFailed:
      return "failed";
    case PlanState::kCancelled:
      return "cancelled";
  }
  return "unknown";
}

PlanSession::PlanSession(std::string id, v1::PlanRequest request, PlanEventLimits limits,
                         std::shared_ptr<const MissionPlan> mission)
    : id_(std::move(id)),
      request_(std::move(request)),
      mission_(std::move(mission)),
      events_(limits) {}

PlanSession::~PlanSession() {
  {
    absl::MutexLock lock(&mu_);
    stopped_ = true;
    if (call_) call_->TryCancel();
  }
  if (thread_.joinable()) thread_.join();
}

std::shared_ptr<grpc::ClientContext> PlanSession::NewCall() {
  absl::MutexLock lock(&mu_);
  if (cancel_requested_ || stopped_) return nullptr;
  call_ = std::make_shared<grpc::ClientContext>();
  return call_;
}

void PlanSession::EndBeforeCall() {
  if (EndIfCancelled(grpc::Status(grpc::StatusCode::CANCELLED, ""))) return;
  Append("failed",
         nlohmann::json{{"code", "CANCELLED"}, {"message", "the gateway is shutting down"}}.dump(),
         PlanState::kFailed);
}

bool PlanSession::EndIfCancelled(const grpc::Status& status) {
  bool cancelled;
  {
    absl::MutexLock lock(&mu_);
    cancelled = cancel_requested_;
  }
  if (!cancelled || (!status.ok() && status.error_code() != grpc::StatusCode::CANCELLED)) {
    return false;
  }
  Append("cancelled",
         nlohmann::json{{"message", "cancelled from the page; the server stopped the plan"}}.dump(),
         PlanState::kCancelled);
  return true;
}

void PlanSession::Start(v1::Planner::Stub* stub) {
  thread_ = std::thread([this, stub] { Run(stub); });
}

namespace {

double Round(double v, double unit) { return std::round(v / unit) * unit; }

}  // namespace

// The display path is for drawing ("not for evaluation", says the API): to
// the centimetre and the ten-thousandth of a radian (1e-7 degrees in WGS84,
// a centimetre too) its JSON is about half as long, and every viewer of
// every improvement receives it. The waypoints, which the page evaluates and
// exports, keep every digit.
void RoundDisplayPath(v1::Trajectory* t) {
  for (v1::Pose& p : *t->mutable_path()) {
    p.set_x(Round(p.x(), 0.01));
    p.set_y(Round(p.y(), 0.01));
    p.set_z(Round(p.z(), 0.01));
    p.set_theta(Round(p.theta(), 1e-4));
  }
  for (v1::GeoPose& p : *t->mutable_path_wgs84()) {
    p.set_lat_deg(Round(p.lat_deg(), 1e-7));
    p.set_lon_deg(Round(p.lon_deg(), 1e-7));
    p.set_alt_m(Round(p.alt_m(), 0.01));
    p.set_heading_deg(Round(p.heading_deg(), 1e-2));
  }
}

void PlanSession::Run(v1::Planner::Stub* stub) {
  if (mission_ != nullptr) return RunMission(stub);
  std::shared_ptr<grpc::ClientContext> context = NewCall();
  if (context == nullptr) return EndBeforeCall();
  std::unique_ptr<grpc::ClientReader<v1::PlanUpdate>> reader =
      stub->PlanTrajectory(context.get(), request_);
  v1::PlanUpdate update;
  bool got_final = false;
  while (reader->Read(&update)) {
    // Stamped on arrival, before conversion, so that the page's latency
    // includes the gateway's own work.
    const double received_ms = EpochMs();
    if (update.has_trajectory()) RoundDisplayPath(update.mutable_trajectory());
    std::string data = absl::StrCat("{\"gateway_ms\":", absl::StrFormat("%.3f", received_ms),
                                    ",\"update\":", ToJson(update), "}");
    if (update.final()) {
      got_final = true;
      Append("final", std::move(data), PlanState::kFinished);
    } else {
      Append("update", std::move(data), PlanState::kRunning);
    }
  }
  const grpc::Status status = reader->Finish();
  if (got_final && status.ok()) return;
  if (!status.ok() && EndIfCancelled(status)) return;
  // The server's own words, untouched: the page shows them as they are.
  Append("failed",
         nlohmann::json{{"code", client::StatusCodeName(status.error_code())},
                        {"message", status.error_message()}}
             .dump(-1, ' ', false, nlohmann::json::error_handler_t::replace),
         PlanState::kFailed);
}

void PlanSession::Append(const std::string& type, std::string data, PlanState end_state) {
  // The state changes before the event is seen: a viewer woken by the
  // terminal event reads the session ended.
  absl::MutexLock lock(&mu_);
  if (state_ != PlanState::kRunning) return;  // nothing after the terminal event
  state_ = end_state;
  events_.Append(type, std::move(data), end_state != PlanState::kRunning);
}

bool PlanSession::Cancel() {
  absl::MutexLock lock(&mu_);
  if (state_ != PlanState::kRunning) return false;
  cancel_requested_ = true;
  if (call_) call_->TryCancel();
  return true;
}

void PlanSession::Stop() {
  {
    absl::MutexLock lock(&mu_);
    stopped_ = true;
    if (call_) call_->TryCancel();
  }
  events_.Stop();
}

PlanState PlanSession::state() const {
  absl::MutexLock lock(&mu_);
  return state_;
}

bool PlanSession::ended() const { return state() != PlanState::kRunning; }

uint64_t PlanSession::last_event_id() const { return events_.last_event_id(); }

std::pair<uint64_t, uint64_t> PlanSession::kept_range() const { return events_.kept_range(); }

PlanRegistry::PlanRegistry(v1::Planner::Stub* stub, PlanRegistryLimits limits)
    : stub_(stub), limits_(limits) {}

PlanRegistry::~PlanRegistry() { StopAll(); }

absl::StatusOr<std::shared_ptr<PlanSession>> PlanRegistry::Start(
    v1::PlanRequest request, std::shared_ptr<const MissionPlan> mission) {
  absl::StatusOr<std::shared_ptr<PlanSession>> session = sessions_.Add(
      limits_.max_running, limits_.max_kept,
      absl::StrFormat("this gateway runs at most %d plans at once (--max_running_plans); cancel "
                      "one or wait for one to end",
                      limits_.max_running),
      "", [&](std::string id) {
        return std::make_shared<PlanSession>(std::move(id), std::move(request), limits_.events,
                                             std::move(mission));
      });
  if (session.ok()) (*session)->Start(stub_);
  return session;
}

}  // namespace riskplan::web
