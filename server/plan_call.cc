#include "server/plan_call.h"

#include <chrono>
#include <utility>

#include "absl/strings/str_format.h"
#include "absl/time/clock.h"
#include "server/proto_convert.h"
#include "server/rpc_log.h"
#include "server/status_util.h"

namespace riskplan::server {

// ---------------------------------------------------------------------------
// ActivePlans

bool ActivePlans::TryAdmit(const std::shared_ptr<PlanCall>& call) {
  absl::MutexLock lock(&mu_);
  if (static_cast<int>(calls_.size()) >= max_running_) return false;
  calls_.insert(call);
  return true;
}

void ActivePlans::Release(const PlanCall* call) {
  absl::MutexLock lock(&mu_);
  for (auto it = calls_.begin(); it != calls_.end(); ++it) {
    if (it->get() == call) {
      calls_.erase(it);
      return;
    }
  }
}

void ActivePlans::StopAll() {
  std::set<std::shared_ptr<PlanCall>> calls;
  {
    absl::MutexLock lock(&mu_);
    calls = calls_;
  }
  for (const std::shared_ptr<PlanCall>& call : calls) call->StopForShutdown();
}

bool ActivePlans::WaitUntilIdle(absl::Time deadline) {
  absl::MutexLock lock(&mu_);
  auto idle = [this]() { return calls_.empty(); };
  return mu_.AwaitWithDeadline(absl::Condition(&idle), deadline);
}

int ActivePlans::running() const {
  absl::MutexLock lock(&mu_);
  return static_cast<int>(calls_.size());
}

// ---------------------------------------------------------------------------
// PlanCall

namespace {

std::string PeerOf(grpc::CallbackServerContext* ctx) { return ctx == nullptr ? "" : ctx->peer(); }

}  // namespace

std::shared_ptr<PlanCall> PlanCall::Create(const PlanCallEnv& env, grpc::CallbackServerContext* ctx,
                                           PlanSpec spec) {
  std::shared_ptr<PlanCall> call(new PlanCall(env, ctx, std::move(spec)));
  call->self_ = call;
  if (env.open_calls != nullptr) env.open_calls->Opened();
  return call;
}

PlanCall::PlanCall(const PlanCallEnv& env, grpc::CallbackServerContext* ctx, PlanSpec spec)
    : env_(env),
      ctx_(ctx),
      spec_(std::move(spec)),
      started_(absl::Now()),
      peer_(PeerOf(ctx)),
      coalescer_(spec_.min_update_interval) {}

absl::Status PlanCall::CheckEndpointsIfModelReady() {
  std::shared_ptr<const RiskModel> model = env_.models->Peek(*spec_.map, spec_.params);
  if (model == nullptr) return absl::OkStatus();
  absl::Status status = CheckEndpoints(PlanningProblem{model, spec_.start, spec_.goal});
  if (status.ok()) endpoints_checked_.store(true);
  return status;
}

void PlanCall::Reject(const grpc::Status& status) { FinishWith(status); }

void PlanCall::StopForShutdown() {
  shutdown_.store(true);
  cancel_.Cancel();
}

void PlanCall::Run() {
  std::shared_ptr<PlanCall> keep = shared_from_this();
  absl::Status error;
  PlanResult result;
  result.reason = StopReason::kCancelled;
  // A call cancelled while queued (client gone, or shutdown) does not plan.
  if (!cancel_.IsCancelled()) {
    const uint64_t builds_before = env_.models->stats().builds;
    absl::StatusOr<std::shared_ptr<const RiskModel>> model =
        env_.models->Get(*spec_.map, spec_.params);
    if (env_.models->stats().builds != builds_before) env_.metrics->RecordModelBuild();
    if (!model.ok()) {
      error = model.status();
    } else {
      const PlanningProblem problem{*model, spec_.start, spec_.goal};
      if (!endpoints_checked_.load()) error = CheckEndpoints(problem);
      if (error.ok()) {
        // One evaluator per plan: it counts the plan's configurations.
        std::unique_ptr<RiskEvaluator> evaluator =
            env_.engine != nullptr ? env_.engine->NewEvaluator() : nullptr;
        absl::StatusOr<std::unique_ptr<Planner>> planner =
            MakePlanner(spec_.algorithm, evaluator.get());
        if (!planner.ok()) {
          error = planner.status();
        } else {
          absl::StatusOr<PlanResult> planned = (*planner)->Plan(
              problem, spec_.options, cancel_,
              [this](const PlanImprovement& improvement) { OnImprovement(improvement); });
          if (planned.ok()) {
            result = *std::move(planned);
          } else {
            error = planned.status();
          }
        }
      }
    }
  }
  // The slot is free as soon as the planner is: the final message may still
  // be on its way to a slow client.
  env_.active->Release(this);
  env_.metrics->PlanReleased();
  if (!error.ok()) {
    FinishWith(ToGrpcStatus(error));
    return;
  }
  v1::PlanUpdate final_update = FinalUpdate(result);
  env_.metrics->RecordPlan(v1::EndReason_Name(final_update.end_reason()),
                           absl::Seconds(result.elapsed_s));

  bool write = false;
  {
    absl::MutexLock lock(&mu_);
    log_detail_ = absl::StrFormat(
        "end_reason=%s iterations=%d tree_size=%d improvements=%d risk=%.9g planner_s=%.3f",
        v1::EndReason_Name(final_update.end_reason()), result.iterations, result.tree_size,
        improvements_, result.best.has_value() ? result.best->risk : -1.0, result.elapsed_s);
    if (finish_started_) return;
    if (cancelled_ || write_failed_) {
      // Nobody is listening: end without writing.
      if (!coalescer_.write_in_flight()) {
        finish_started_ = true;
        final_status_ = grpc::Status(grpc::StatusCode::CANCELLED, "the call was cancelled");
      } else {
        finish_when_idle_ = grpc::Status(grpc::StatusCode::CANCELLED, "the call was cancelled");
        return;
      }
    } else {
      final_update.set_improvements(improvements_);
      Step step = coalescer_.OfferFinal(std::move(final_update), absl::Now());
      write = TakeWriteLocked(&step);
      if (!write) return;  // sent when the write in flight completes
    }
  }
  if (write) {
    StartWrite(&write_buffer_);
  } else {
    Finish(grpc::Status(grpc::StatusCode::CANCELLED, "the call was cancelled"));
  }
}

v1::PlanUpdate PlanCall::FinalUpdate(const PlanResult& result) {
  v1::PlanUpdate update;
  update.set_final(true);
  update.set_end_reason(EndReasonToProto(result.reason, shutdown_.load()));
  update.set_elapsed_s(result.elapsed_s);
  update.set_iterations(result.iterations);
  update.set_tree_size(result.tree_size);
  update.set_configurations_evaluated(result.configurations_evaluated);
  if (result.best.has_value()) {
    // Waypoints, risk and length are always set; only the display path can
    // be missing, and only if the planner returned malformed waypoints.
    (void)TrajectoryToProto(*result.best, spec_.params, spec_.display_step_m,
                            update.mutable_trajectory());
  }
  if (spec_.options.record_tree) {
    const size_t edges = std::min(result.tree.size(), kMaxTreeEdges);
    update.mutable_tree_edges()->Reserve(static_cast<int>(edges));
    for (size_t i = 0; i < edges; ++i) {
      v1::TreeEdge* edge = update.add_tree_edges();
      PoseToProto(result.tree[i].from, edge->mutable_from());
      PoseToProto(result.tree[i].to, edge->mutable_to());
    }
    update.set_tree_truncated(result.tree.size() > edges);
  }
  return update;
}

void PlanCall::OnImprovement(const PlanImprovement& improvement) {
  // Built outside the lock: the planner thread pays for it, not gRPC's.
  v1::PlanUpdate update;
  update.set_elapsed_s(improvement.elapsed_s);
  update.set_iterations(improvement.iterations);
  update.set_tree_size(improvement.tree_size);
  (void)TrajectoryToProto(improvement, spec_.params, spec_.display_step_m,
                          update.mutable_trajectory());
  Step step;
  {
    absl::MutexLock lock(&mu_);
    ++improvements_;
    if (finish_started_ || cancelled_ || write_failed_) return;
    update.set_improvements(improvements_);
    step = coalescer_.Offer(std::move(update), absl::Now());
    if (!TakeWriteLocked(&step)) step.write.reset();
  }
  Perform(std::move(step));
}

void PlanCall::OnTimer() {
  Step step;
  {
    absl::MutexLock lock(&mu_);
    if (finish_started_ || cancelled_ || write_failed_) return;
    step = coalescer_.Poll(absl::Now());
    if (!TakeWriteLocked(&step)) step.write.reset();
  }
  Perform(std::move(step));
}

bool PlanCall::TakeWriteLocked(Step* step) {
  if (step->finish) {
    finish_started_ = true;
    return false;
  }
  if (!step->write.has_value()) return false;
  write_buffer_ = std::move(*step->write);
  write_buffer_.set_sequence(++sent_);
  return true;
}

void PlanCall::Perform(Step step) {
  if (step.wake_at.has_value()) {
    env_.timer->Schedule(*step.wake_at, [self = shared_from_this()] { self->OnTimer(); });
  }
  if (step.write.has_value()) {
    StartWrite(&write_buffer_);
  } else if (step.finish) {
    grpc::Status status;
    {
      absl::MutexLock lock(&mu_);
      status = final_status_;
    }
    Finish(status);
  }
}

void PlanCall::FinishWith(const grpc::Status& status) {
  {
    absl::MutexLock lock(&mu_);
    if (finish_started_) return;
    if (coalescer_.write_in_flight()) {
      finish_when_idle_ = status;
      return;
    }
    finish_started_ = true;
    final_status_ = status;
  }
  Finish(status);
}

void PlanCall::OnWriteDone(bool ok) {
  std::shared_ptr<PlanCall> keep = shared_from_this();
  Step step;
  {
    absl::MutexLock lock(&mu_);
    if (!ok) {
      // The client is gone: stop planning, and finish once Run() is done
      // with the call (it offers the final message, or already has).
      write_failed_ = true;
      // Nothing is in flight any more: Run() must not wait for this write to
      // complete before it finishes the call (it would wait forever).
      coalescer_.OnWriteFailed();
      cancel_.Cancel();
      if (finish_started_ || (!coalescer_.final_offered() && !finish_when_idle_.has_value())) {
        return;
      }
      finish_started_ = true;
      final_status_ = grpc::Status(grpc::StatusCode::CANCELLED, "the stream broke");
      step.finish = true;
    } else if (finish_when_idle_.has_value()) {
      finish_started_ = true;
      final_status_ = *finish_when_idle_;
      step.finish = true;
    } else {
      step = coalescer_.OnWriteDone(absl::Now());
      if (!TakeWriteLocked(&step)) step.write.reset();
    }
  }
  Perform(std::move(step));
}

void PlanCall::OnCancel() {
  {
    absl::MutexLock lock(&mu_);
    cancelled_ = true;
    deadline_hit_ = ctx_->deadline() <= std::chrono::system_clock::now();
  }
  cancel_.Cancel();
}

void PlanCall::OnDone() {
  grpc::Status status;
  std::string detail;
  int64_t sent = 0, replaced = 0;
  {
    absl::MutexLock lock(&mu_);
    status = final_status_;
    if (cancelled_) {
      status = deadline_hit_
                   ? grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED, "the call's deadline passed")
                   : grpc::Status(grpc::StatusCode::CANCELLED, "the client cancelled");
    }
    detail = log_detail_;
    sent = static_cast<int64_t>(sent_);
    replaced = coalescer_.replaced();
  }
  const absl::Duration duration = absl::Now() - started_;
  env_.metrics->RecordRpc("PlanTrajectory", status.error_code(), duration);
  env_.metrics->RecordUpdates(sent, replaced);
  if (!detail.empty()) detail += absl::StrFormat(" sent=%d replaced=%d", sent, replaced);
  LogRpc({.method = "PlanTrajectory",
          .status = status,
          .duration = duration,
          .peer = peer_,
          .map = spec_.map ? spec_.map->name() : "",
          .detail = detail});
  if (env_.open_calls != nullptr) env_.open_calls->Done();
  // Drops gRPC's reference last: this may destroy the call.
  std::shared_ptr<PlanCall> last = std::move(self_);
}

}  // namespace riskplan::server
