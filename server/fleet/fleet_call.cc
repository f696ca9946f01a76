#include "server/fleet/fleet_call.h"

#include <chrono>
#include <utility>

#include "absl/strings/str_format.h"
#include "absl/time/clock.h"
#include "core/base/check.h"
#include "server/api/message_codec.h"
#include "server/api/proto_convert.h"
#include "server/observability/rpc_log.h"
#include "server/api/status_util.h"

namespace riskplan::server {

std::shared_ptr<FleetCall> FleetCall::Create(grpc::CallbackServerContext* ctx,
                                             ServerMetrics* metrics, OpenCalls* open_calls,
                                             Caller caller) {
  std::shared_ptr<FleetCall> call(new FleetCall(ctx, metrics, open_calls, std::move(caller)));
  // gRPC holds a raw pointer to the reactor until OnDone: self_ stands for it.
  call->self_ = call;
  if (open_calls != nullptr) open_calls->Opened();
  return call;
}

FleetCall::FleetCall(grpc::CallbackServerContext* ctx, ServerMetrics* metrics,
                     OpenCalls* open_calls, Caller caller)
    : ctx_(ctx),
      metrics_(metrics),
      open_calls_(open_calls),
      caller_(std::move(caller)),
      started_(absl::Now()),
      peer_(ctx == nullptr ? "" : ctx->peer()) {}

void FleetCall::Reject(const grpc::Status& status) {
  Step step;
  {
    absl::MutexLock lock(&mu_);
    step = state_.Reject(status);
  }
  Perform(step);
}

void FleetCall::Start(std::shared_ptr<const FleetSpec> spec, int groups,
                      std::function<void()> on_cancel) {
  std::vector<v1::FleetUpdate> errors;
  // Invalid missions never offer improvements: their interval is never read.
  std::vector<absl::Duration> min_update_intervals(spec->missions.size(), absl::ZeroDuration());
  for (size_t i = 0; i < spec->missions.size(); ++i) {
    const FleetMissionSpec& m = spec->missions[i];
    if (m.plan.ok()) {
      min_update_intervals[i] = m.plan->min_update_interval;
      continue;
    }
    v1::FleetUpdate u;
    u.set_mission_id(m.id);
    u.set_mission_index(static_cast<int>(i));
    const grpc::Status status = ToGrpcStatus(m.plan.status());
    u.set_error_code(status.error_code());
    u.set_error_message(status.error_message());
    errors.push_back(std::move(u));
  }
  Step step;
  {
    absl::MutexLock lock(&mu_);
    const size_t n = spec->missions.size();
    spec_ = std::move(spec);
    on_cancel_ = std::move(on_cancel);
    mission_sequence_.assign(n, 0);
    mission_improvements_.assign(n, 0);
    // The errors end their missions now, unless the client left before the
    // stream began: then the state drops them, and the groups.
    if (state_.phase() == FleetCallPhase::kCreated) {
      for (v1::FleetUpdate& u : errors) {
        u.set_missions_ended(++missions_ended_);
        ++failed_;
      }
    }
    step = state_.Start(groups, std::move(min_update_intervals), std::move(errors), absl::Now());
    TakeWriteLocked(&step);
  }
  Perform(step);
}

void FleetCall::OfferImprovement(size_t mission, const PlanImprovement& improvement) {
  std::shared_ptr<const FleetSpec> spec;
  {
    absl::MutexLock lock(&mu_);
    if (!state_.takes_offers() || !spec_->send_improvements) return;
    spec = spec_;
  }
  const FleetMissionSpec& m = spec->missions[mission];
  // Built outside the lock: the planner's thread pays for it.
  absl::StatusOr<v1::PlanUpdate> update =
      ImprovementToProto(improvement, m.plan->params, m.plan->display_step_m, m.plan->frame.get());
  if (!update.ok()) return;  // never for a planner's output; the final carries a newer one
  Step step;
  {
    absl::MutexLock lock(&mu_);
    if (!state_.takes_offers()) return;
    update->set_improvements(++mission_improvements_[mission]);
    *update->mutable_wind() = m.plan->wind;
    v1::FleetUpdate u;
    u.set_mission_id(m.id);
    u.set_mission_index(static_cast<int>(mission));
    *u.mutable_update() = *std::move(update);
    step = state_.OfferImprovement(mission, std::move(u), absl::Now());
    TakeWriteLocked(&step);
  }
  Perform(step);
}

void FleetCall::OfferResult(size_t mission, const absl::StatusOr<PlanResult>& result) {
  std::shared_ptr<const FleetSpec> spec;
  int64_t improvements = 0;
  {
    absl::MutexLock lock(&mu_);
    spec = spec_;
    improvements = mission_improvements_[mission];
  }
  const FleetMissionSpec& m = spec->missions[mission];
  v1::FleetUpdate u;
  u.set_mission_id(m.id);
  u.set_mission_index(static_cast<int>(mission));
  absl::Status error = result.status();
  if (result.ok()) {
    const v1::EndReason end_reason = EndReasonToProto(result->reason, shutdown_.load());
    metrics_->RecordPlan(v1::EndReason_Name(end_reason), absl::Seconds(result->elapsed_s));
    absl::StatusOr<v1::PlanUpdate> final_update =
        FinalUpdateToProto(*result, end_reason, m.plan->params, m.plan->display_step_m,
                           m.plan->options.record_tree, m.plan->frame.get());
    if (final_update.ok()) {
      final_update->set_improvements(improvements);
      *final_update->mutable_wind() = m.plan->wind;
      *u.mutable_update() = *std::move(final_update);
    } else {
      error = MissionError(mission, final_update.status());
    }
  }
  if (!error.ok()) {
    const grpc::Status status = ToGrpcStatus(error);
    u.set_error_code(status.error_code());
    u.set_error_message(status.error_message());
  }
  OfferFinal(mission, std::move(u));
}

void FleetCall::OfferFinal(size_t mission, v1::FleetUpdate update) {
  Step step;
  {
    absl::MutexLock lock(&mu_);
    // Once the client has gone, results are not counted: their missions
    // are the cancelled ones.
    if (!state_.takes_offers()) return;
    update.set_missions_ended(++missions_ended_);
    if (update.has_update()) {
      ++completed_;
    } else {
      ++failed_;
    }
    step = state_.OfferFinal(mission, std::move(update), absl::Now());
    TakeWriteLocked(&step);
  }
  Perform(step);
}

void FleetCall::GroupEnded() {
  Step step;
  {
    absl::MutexLock lock(&mu_);
    step = state_.GroupEnded(absl::Now());
    TakeWriteLocked(&step);
  }
  Perform(step);
}

void FleetCall::StopForShutdown() {
  MarkShutdown();
  cancel_.Cancel();
}

void FleetCall::TakeWriteLocked(Step* step) {
  if (!step->write.has_value()) return;
  write_buffer_ = std::move(*step->write);
  // Numbered here, at the moment it is sent, so that sequence numbers have
  // no gaps however many improvements were replaced.
  const size_t m = static_cast<size_t>(write_buffer_.mission_index());
  if (write_buffer_.has_update()) {
    write_buffer_.mutable_update()->set_sequence(++mission_sequence_[m]);
  }
  write_buffer_.set_sequence(++sent_);
}

void FleetCall::Perform(const Step& step) {
  if (step.stop_planners) {
    cancel_.Cancel();
    // Set by Start, before the state can ask for this; asked once a call.
    if (on_cancel_) on_cancel_();
  }
  if (step.write) {
    if (absl::Status s = SerializeMessage(write_buffer_, &raw_write_); !s.ok()) {
      LogEvent("fleet_update_failed", absl::StrFormat("peer=%s: %s", peer_, s.message()));
      OnWriteDone(false);
      return;
    }
    StartWrite(&raw_write_);
  } else if (step.finish.has_value()) {
    Finish(*step.finish);
  }
}

void FleetCall::OnWriteDone(bool ok) {
  // Finish, started below, may let OnDone drop gRPC's reference on another
  // thread while this reaction still runs.
  std::shared_ptr<FleetCall> keep = shared_from_this();
  Step step;
  {
    absl::MutexLock lock(&mu_);
    // A failed write means the client is gone: the state stops the planners
    // and finishes the call once every group has ended.
    step = ok ? state_.WriteDone(absl::Now()) : state_.WriteFailed();
    TakeWriteLocked(&step);
  }
  Perform(step);
}

void FleetCall::OnCancel() {
  const bool deadline_passed = ctx_->deadline() <= std::chrono::system_clock::now();
  Step step;
  {
    absl::MutexLock lock(&mu_);
    step = state_.Cancel(deadline_passed ? CancelCause::kDeadline : CancelCause::kClient);
  }
  Perform(step);
}

void FleetCall::OnDone() {
  grpc::Status status;
  int missions = 0, completed = 0, failed = 0;
  uint64_t sent = 0;
  {
    absl::MutexLock lock(&mu_);
    // gRPC calls OnDone only after Finish: the state must have got there.
    RISKPLAN_DCHECK(state_.phase() == FleetCallPhase::kFinished);
    status = state_.ReportedStatus();
    missions = spec_ == nullptr ? 0 : static_cast<int>(spec_->missions.size());
    completed = completed_;
    failed = failed_;
    sent = sent_;
  }
  const absl::Duration duration = absl::Now() - started_;
  metrics_->RecordRpc("PlanFleet", status.error_code(), duration, caller_.label);
  if (missions > 0)
    metrics_->RecordFleetMissionsEnded(completed, failed, missions - completed - failed);
  LogRpc({.method = "PlanFleet",
          .status = status,
          .duration = duration,
          .peer = peer_,
          .identity = caller_.identity,
          .map = "",
          .detail = missions == 0 ? ""
                                  : absl::StrFormat("missions=%d completed=%d failed=%d sent=%d",
                                                    missions, completed, failed, sent)});
  // After the log line: the drain waits for open calls.
  if (open_calls_ != nullptr) open_calls_->Done();
  std::shared_ptr<FleetCall> last = std::move(self_);
}

}  // namespace riskplan::server
