#include "server/flight/flight_call.h"

#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "server/observability/rpc_log.h"
#include "server/api/status_util.h"

namespace riskplan::server {

std::shared_ptr<FlightCall> FlightCall::Create(const FlightCallEnv& env,
                                               grpc::CallbackServerContext* ctx, Caller caller) {
  std::shared_ptr<FlightCall> call(new FlightCall(env, ctx, std::move(caller)));
  call->self_ = call;
  if (env.open_calls != nullptr) env.open_calls->Opened();
  return call;
}

FlightCall::FlightCall(const FlightCallEnv& env, grpc::CallbackServerContext* ctx, Caller caller)
    : env_(env),
      started_(absl::Now()),
      peer_(ctx->peer()),
      caller_(std::move(caller)),
      session_(env.flight) {
  // Only the step running on the pool calls it (the session's thread).
  session_.set_early_sink([this](v1::FlightOutput o) { EmitEarly(std::move(o)); });
}

void FlightCall::QueueLocked(v1::FlightOutput o) {
  versions_ += o.has_plan() ? 1 : 0;
  alerts_ += o.has_alert() ? 1 : 0;
  refusals_ += o.has_refusal() ? 1 : 0;
  outputs_.push_back(std::move(o));
}

void FlightCall::EmitEarly(v1::FlightOutput output) {
  {
    absl::MutexLock lock(&mu_);
    if (end_.has_value()) return;
    QueueLocked(std::move(output));
  }
  Pump();
}

void FlightCall::Start() {
  {
    absl::MutexLock lock(&mu_);
    admitted_ = true;
  }
  absl::MutexLock ops(&ops_mu_);
  if (!finish_started_) StartRead(&read_buffer_);
}

void FlightCall::Reject(const grpc::Status& status) {
  {
    absl::MutexLock lock(&mu_);
    reads_done_ = true;
    EndLocked(status);
  }
  Pump();
}

void FlightCall::StopForShutdown() {
  shutdown_.Cancel();
  cancel_.Cancel();
  {
    absl::MutexLock lock(&mu_);
    EndLocked(grpc::Status(grpc::StatusCode::UNAVAILABLE,
                           "riskplan-server is shutting down; open the session again (resume) on "
                           "another replica"));
  }
  Pump();
}

void FlightCall::OnReadDone(bool ok) {
  bool read_again = false;
  bool schedule = false;
  {
    absl::MutexLock lock(&mu_);
    if (!ok) {
      // The client half-closed (or the stream broke): no more inputs.
      reads_done_ = true;
      if (!step_scheduled_ && inputs_.empty()) EndLocked(grpc::Status::OK);
    } else if (end_.has_value()) {
      // Ending: inputs are dropped.
    } else if (inputs_.size() >= kMaxQueuedInputs) {
      cancel_.Cancel();
      EndLocked(grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                             absl::StrCat("more than ", kMaxQueuedInputs,
                                          " inputs wait for the session: send them no faster "
                                          "than it answers")));
    } else {
      ++inputs_read_;
      inputs_.push_back(std::move(read_buffer_));
      read_buffer_.Clear();
      schedule = ScheduleLocked();
      read_again = true;
    }
  }
  if (schedule && !env_.pool->TrySubmit([self = shared_from_this()] { self->Step(); })) {
    absl::MutexLock lock(&mu_);
    step_scheduled_ = false;
    EndLocked(grpc::Status(grpc::StatusCode::UNAVAILABLE, "riskplan-server is shutting down"));
  }
  if (read_again) {
    absl::MutexLock ops(&ops_mu_);
    if (!finish_started_) StartRead(&read_buffer_);
  }
  Pump();
}

bool FlightCall::ScheduleLocked() {
  if (step_scheduled_ || end_.has_value()) return false;
  step_scheduled_ = true;
  return true;
}

void FlightCall::Step() {
  std::optional<v1::FlightInput> input;
  bool search = false;
  {
    absl::MutexLock lock(&mu_);
    if (end_.has_value()) {
      step_scheduled_ = false;
      return;
    }
    if (!inputs_.empty()) {
      input = std::move(inputs_.front());
      inputs_.pop_front();
    } else {
      search = session_.searching();
    }
  }
  std::vector<v1::FlightOutput> outs;
  std::optional<grpc::Status> end;
  try {
    if (input.has_value()) {
      absl::StatusOr<std::vector<v1::FlightOutput>> r = session_.Handle(*input, cancel_);
      if (!r.ok()) {
        end = ToGrpcStatus(r.status());
      } else {
        outs = *std::move(r);
        if (session_.ended()) end = grpc::Status::OK;
      }
    } else if (search) {
      outs = session_.Search(cancel_);
    }
  } catch (const std::exception& e) {
    end = grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                       absl::StrCat("the session failed: ", e.what()));
  }
  bool again = false;
  {
    absl::MutexLock lock(&mu_);
    for (v1::FlightOutput& o : outs) QueueLocked(std::move(o));
    if (map_.empty()) map_ = session_.map_name();
    if (outputs_.size() > kMaxQueuedOutputs) {
      end = grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                         absl::StrCat("more than ", kMaxQueuedOutputs,
                                      " outputs wait for the client: it does not read"));
    }
    step_scheduled_ = false;
    if (end.has_value()) {
      EndLocked(*end);
    } else if (reads_done_ && inputs_.empty()) {
      EndLocked(grpc::Status::OK);
    } else if (!inputs_.empty() || (session_.searching() && !cancel_.IsCancelled())) {
      again = ScheduleLocked();
    }
  }
  if (again && !env_.pool->TrySubmit([self = shared_from_this()] { self->Step(); })) {
    absl::MutexLock lock(&mu_);
    step_scheduled_ = false;
    EndLocked(grpc::Status(grpc::StatusCode::UNAVAILABLE, "riskplan-server is shutting down"));
  }
  Pump();
}

void FlightCall::EndLocked(const grpc::Status& status) {
  if (!end_.has_value()) end_ = status;
}

void FlightCall::Pump() {
  enum { kNothing, kWrite, kFinish } action = kNothing;
  grpc::Status status;
  {
    absl::MutexLock lock(&mu_);
    if (finished_ || writing_) return;
    // An error ends at once (outputs dropped); OK after every output is written.
    const bool drop = end_.has_value() && !end_->ok();
    if (!outputs_.empty() && !drop) {
      write_buffer_ = std::move(outputs_.front());
      outputs_.pop_front();
      writing_ = true;
      action = kWrite;
    } else if (end_.has_value() && !step_scheduled_) {
      finished_ = true;
      status = *end_;
      finish_status_ = status;
      action = kFinish;
    }
  }
  if (action == kWrite) {
    StartWrite(&write_buffer_);
  } else if (action == kFinish) {
    cancel_.Cancel();
    absl::MutexLock ops(&ops_mu_);
    finish_started_ = true;
    Finish(status);
  }
}

void FlightCall::OnWriteDone(bool ok) {
  {
    absl::MutexLock lock(&mu_);
    writing_ = false;
    if (!ok) {
      cancel_.Cancel();
      EndLocked(grpc::Status(grpc::StatusCode::CANCELLED, "the stream broke"));
    }
  }
  Pump();
}

void FlightCall::OnCancel() {
  cancel_.Cancel();
  {
    absl::MutexLock lock(&mu_);
    EndLocked(grpc::Status(grpc::StatusCode::CANCELLED, "the client cancelled the session"));
  }
  Pump();
}

void FlightCall::OnDone() {
  bool admitted = false;
  grpc::Status status;
  std::string detail, map;
  {
    absl::MutexLock lock(&mu_);
    admitted = admitted_;
    status = finish_status_;
    map = map_;
    detail = absl::StrFormat("inputs=%d versions=%d alerts=%d refusals=%d", inputs_read_,
                             versions_, alerts_, refusals_);
  }
  const absl::Duration duration = absl::Now() - started_;
  if (env_.metrics != nullptr) {
    env_.metrics->RecordRpc("Fly", status.error_code(), duration, caller_.label);
  }
  LogRpc({.method = "Fly",
          .status = status,
          .duration = duration,
          .peer = peer_,
          .identity = caller_.identity,
          .map = map,
          .detail = status.ok() ? detail : absl::StrCat(status.error_message(), "; ", detail)});
  if (admitted && env_.active != nullptr) {
    env_.active->Release(this);
    if (env_.metrics != nullptr) env_.metrics->PlanReleased(ServerMetrics::PlanKind::kTrajectory);
  }
  if (env_.open_calls != nullptr) env_.open_calls->Done();
  self_.reset();
}

}  // namespace riskplan::server
