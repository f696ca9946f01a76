#include "server/fleet/fleet_call.h"

#include <chrono>
#include <utility>

#include "absl/strings/str_format.h"
#include "absl/time/clock.h"
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
  {
    absl::MutexLock lock(&mu_);
    if (finished_) return;
    finished_ = true;
    status_ = status;
  }
  Finish(status);
}

void FleetCall::Start(std::shared_ptr<const FleetSpec> spec, int groups,
                      std::function<void()> on_cancel) {
  std::vector<v1::FleetUpdate> errors;
  for (size_t i = 0; i < spec->missions.size(); ++i) {
    const FleetMissionSpec& m = spec->missions[i];
    if (m.plan.ok()) continue;
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
    groups_running_ = groups;
    on_cancel_ = std::move(on_cancel);
    improvement_sent_.assign(n, absl::InfinitePast());
    mission_sequence_.assign(n, 0);
    mission_improvements_.assign(n, 0);
    started_stream_ = true;
    if (gone_) {
      // The client left before the stream began: the groups are dropped.
      step.cancel = true;
    } else {
      for (v1::FleetUpdate& u : errors) {
        u.set_missions_ended(++missions_ended_);
        ++failed_;
        finals_.push_back(std::move(u));
      }
    }
    Step next = NextLocked(absl::Now());
    step.write = next.write;
    step.finish = next.finish;
  }
  Perform(std::move(step));
}

void FleetCall::OfferImprovement(size_t mission, const PlanImprovement& improvement) {
  std::shared_ptr<const FleetSpec> spec;
  {
    absl::MutexLock lock(&mu_);
    if (gone_ || finished_ || !spec_->send_improvements) return;
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
    if (gone_ || finished_) return;
    update->set_improvements(++mission_improvements_[mission]);
    v1::FleetUpdate& u = improvements_[mission];
    u.set_mission_id(m.id);
    u.set_mission_index(static_cast<int>(mission));
    *u.mutable_update() = *std::move(update);
    step = NextLocked(absl::Now());
  }
  Perform(std::move(step));
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
    if (finished_ || gone_) return;
    improvements_.erase(mission);  // the final carries the best trajectory
    update.set_missions_ended(++missions_ended_);
    if (update.has_update()) {
      ++completed_;
    } else {
      ++failed_;
    }
    finals_.push_back(std::move(update));
    step = NextLocked(absl::Now());
  }
  Perform(std::move(step));
}

void FleetCall::GroupEnded() {
  Step step;
  {
    absl::MutexLock lock(&mu_);
    --groups_running_;
    step = NextLocked(absl::Now());
  }
  Perform(std::move(step));
}

void FleetCall::StopForShutdown() {
  MarkShutdown();
  cancel_.Cancel();
}

FleetCall::Step FleetCall::NextLocked(absl::Time now) {
  Step step;
  if (finished_ || write_in_flight_ || !started_stream_) return step;
  if (!gone_) {
    bool take = false;
    if (!finals_.empty()) {
      write_buffer_ = std::move(finals_.front());
      finals_.pop_front();
      take = true;
    } else {
      for (auto it = improvements_.begin(); it != improvements_.end(); ++it) {
        const size_t m = it->first;
        if (now - improvement_sent_[m] < spec_->missions[m].plan->min_update_interval) continue;
        improvement_sent_[m] = now;
        write_buffer_ = std::move(it->second);
        improvements_.erase(it);
        take = true;
        break;
      }
    }
    if (take) {
      const size_t m = static_cast<size_t>(write_buffer_.mission_index());
      if (write_buffer_.has_update()) {
        write_buffer_.mutable_update()->set_sequence(++mission_sequence_[m]);
      }
      write_buffer_.set_sequence(++sent_);
      write_in_flight_ = true;
      step.write = true;
      return step;
    }
  }
  if (groups_running_ > 0 || (!gone_ && !finals_.empty())) return step;
  finished_ = true;
  status_ = gone_ ? grpc::Status(grpc::StatusCode::CANCELLED, "the call was cancelled")
                  : grpc::Status::OK;
  step.finish = status_;
  return step;
}

void FleetCall::GoneLocked(Step* step) {
  if (gone_) return;
  gone_ = true;
  finals_.clear();
  improvements_.clear();
  // Before Start the groups are not queued yet: Start drops them.
  if (started_stream_) step->cancel = true;
}

void FleetCall::Perform(Step step) {
  if (step.cancel) {
    cancel_.Cancel();
    // Set once by Start, before any step can cancel; run once (gone_).
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
    write_in_flight_ = false;
    if (!ok) GoneLocked(&step);
    Step next = NextLocked(absl::Now());
    step.write = next.write;
    step.finish = next.finish;
  }
  Perform(std::move(step));
}

void FleetCall::OnCancel() {
  const bool deadline_passed = ctx_->deadline() <= std::chrono::system_clock::now();
  Step step;
  {
    absl::MutexLock lock(&mu_);
    deadline_ = deadline_passed;
    GoneLocked(&step);
    Step next = NextLocked(absl::Now());
    step.write = next.write;
    step.finish = next.finish;
  }
  Perform(std::move(step));
}

void FleetCall::OnDone() {
  grpc::Status status;
  int missions = 0, completed = 0, failed = 0;
  uint64_t sent = 0;
  {
    absl::MutexLock lock(&mu_);
    status = status_;
    if (gone_) {
      status = deadline_
                   ? grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED, "the call's deadline passed")
                   : grpc::Status(grpc::StatusCode::CANCELLED, "the client cancelled");
    }
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
