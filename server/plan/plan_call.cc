#include "server/plan/plan_call.h"

#include <chrono>
#include <exception>
#include <optional>
#include <utility>

#include "absl/strings/str_format.h"
#include "absl/time/clock.h"
#include "core/base/check.h"
#include "server/api/message_codec.h"
#include "server/api/proto_convert.h"
#include "server/api/status_util.h"
#include "server/observability/rpc_log.h"

namespace riskplan::server {


// ---------------------------------------------------------------------------
// ActivePlans

bool ActivePlans::TryAdmit(const std::shared_ptr<ActivePlan>& plan) {
  absl::MutexLock lock(&mu_);
  if (static_cast<int>(calls_.size()) >= max_running_) return false;
  calls_.insert(plan);
  return true;
}

// A linear search: the set holds at most --max_running_plans calls (a few
// dozen), and a raw pointer cannot look up a set of shared_ptrs directly.
void ActivePlans::Release(const ActivePlan* plan) {
  // The released plan is destroyed (if this was its last reference) outside
  // mu_, and the listener runs outside it too: it may admit another plan.
  std::shared_ptr<ActivePlan> released;
  {
    absl::MutexLock lock(&mu_);
    for (auto it = calls_.begin(); it != calls_.end(); ++it) {
      if (it->get() == plan) {
        released = *it;
        calls_.erase(it);
        break;
      }
    }
  }
  if (released != nullptr && listener_) listener_();
}

bool ActivePlans::IsAdmitted(const ActivePlan* plan) const {
  absl::MutexLock lock(&mu_);
  for (const std::shared_ptr<ActivePlan>& admitted : calls_) {
    if (admitted.get() == plan) return true;
  }
  return false;
}

void ActivePlans::StopAll() {
  // Stopped from a copy, outside mu_: the copy keeps each call alive while
  // it is stopped, no call's lock is taken under mu_, and a call releasing
  // its slot (Run, on a pool thread) does not wait for the whole loop.
  std::set<std::shared_ptr<ActivePlan>> calls;
  {
    absl::MutexLock lock(&mu_);
    calls = calls_;
  }
  for (const std::shared_ptr<ActivePlan>& call : calls) call->StopForShutdown();
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
                                           PlanSpec spec, Caller caller) {
  std::shared_ptr<PlanCall> call(new PlanCall(env, ctx, std::move(spec), std::move(caller)));
  // gRPC holds a raw pointer to the reactor until OnDone: self_ is the
  // reference that stands for it.
  call->self_ = call;
  if (env.open_calls != nullptr) env.open_calls->Opened();
  return call;
}

PlanCall::PlanCall(const PlanCallEnv& env, grpc::CallbackServerContext* ctx, PlanSpec spec,
                   Caller caller)
    : env_(env),
      ctx_(ctx),
      spec_(std::move(spec)),
      started_(absl::Now()),
      peer_(PeerOf(ctx)),
      caller_(std::move(caller)),
      state_(spec_.min_update_interval) {}

absl::Status PlanCall::CheckEndpointsIfModelReady() {
  // Peek never builds: a model that needs building (seconds, for a glide
  // layer) is left to the pool thread, and so is the check.
  std::shared_ptr<const RiskModel> model = env_.models->Peek(*spec_.map, spec_.params);
  if (model == nullptr) return absl::OkStatus();
  absl::Status status = CheckEndpoints(PlanningProblem{model, spec_.start, spec_.goal});
  if (status.ok()) endpoints_checked_.store(true);
  return status;
}

void PlanCall::Reject(const grpc::Status& status) { FinishWith(status); }

void PlanCall::StopForShutdown() {
  Step step;
  {
    absl::MutexLock lock(&mu_);
    step = state_.Shutdown();
  }
  Perform(step);
}

void PlanCall::Run() {
  RISKPLAN_DCHECK(env_.active->IsAdmitted(this));
  // PlanAdmitted() raised the gauge for this call and nothing has lowered it.
  RISKPLAN_DCHECK(env_.metrics->running_plans() >= 1.0);
  // Once Run has finished the call, OnDone may drop gRPC's reference on
  // another thread; the pool task holds one too, but Run does not rely on
  // how it is called.
  std::shared_ptr<PlanCall> keep = shared_from_this();
  absl::StatusOr<PlanResult> result = absl::UnknownError("not planned");
  try {
    result = Plan();
  } catch (const std::exception& e) {
    result = StatusFromException(e, "PlanTrajectory");
  }
  // The slot is free as soon as the planner is: the final message may still
  // be on its way to a slow client.
  env_.active->Release(this);
  env_.metrics->PlanReleased(ServerMetrics::PlanKind::kTrajectory);
  if (!result.ok()) {
    FinishWith(ToGrpcStatus(result.status()));
    return;
  }
  try {
    OfferFinal(*result);
  } catch (const std::exception& e) {
    // Building the final message (tree, display path) ran out of memory.
    FinishWith(ToGrpcStatus(StatusFromException(e, "PlanTrajectory final message")));
  }
}

absl::StatusOr<PlanResult> PlanCall::Plan() {
  // A call cancelled while queued (client gone, or shutdown) does not plan;
  // its (empty) result still goes through OfferFinal, which writes nothing to
  // a gone client and says SHUTDOWN to one that is still there.
  if (cancel_.IsCancelled()) {
    PlanResult cancelled;
    cancelled.reason = StopReason::kCancelled;
    return cancelled;
  }

  // A build is told from a hit by the cache's build count changing around
  // Get: cheap, but a build by another call at the same moment is counted
  // here as well (the metric can over-count under concurrent builds).
  const uint64_t builds_before = env_.models->stats().builds;
  absl::StatusOr<std::shared_ptr<const RiskModel>> model =
      env_.models->Get(*spec_.map, spec_.params);
  if (env_.models->stats().builds != builds_before) env_.metrics->RecordModelBuild();
  // A build stopped by the drain ends the plan as the drain does (its final
  // message says SHUTDOWN), not with an error.
  if (!model.ok() && absl::IsCancelled(model.status()) && cancel_.IsCancelled()) {
    PlanResult cancelled;
    cancelled.reason = StopReason::kCancelled;
    return cancelled;
  }
  if (!model.ok()) return InField("model_params", model.status());

  const PlanningProblem problem{*model, spec_.start, spec_.goal};
  if (!endpoints_checked_.load()) {
    if (absl::Status s = CheckEndpoints(problem); !s.ok()) return s;
  }
  // One evaluator per plan: it counts the plan's configurations. It stops
  // waiting for boards once the plan is cancelled or its time budget is over
  // (measured from here, just before the planner's own clock starts): a
  // stalled or restarting board's chunk is then computed by this thread, and
  // the planner ends on time instead of after the board's request deadline.
  std::optional<std::chrono::steady_clock::time_point> deadline;
  if (spec_.options.budget.max_time_s > 0.0) {
    deadline = std::chrono::steady_clock::now() +
               std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                   std::chrono::duration<double>(spec_.options.budget.max_time_s));
  }
  std::unique_ptr<RiskEvaluator> evaluator =
      NewPlanEvaluator(env_.engine, spec_.options, StopCondition(&cancel_, nullptr, deadline));
  absl::StatusOr<std::unique_ptr<Planner>> planner = MakePlanner(spec_.algorithm, evaluator.get());
  if (!planner.ok()) return planner.status();
  return (*planner)->Plan(
      problem, spec_.options, cancel_,
      [this](const PlanImprovement& improvement) { OnImprovement(improvement); });
}

void PlanCall::OfferFinal(const PlanResult& result) {
  bool stopped_by_shutdown = false;
  {
    absl::MutexLock lock(&mu_);
    stopped_by_shutdown = state_.stopped_by_shutdown();
  }
  const v1::EndReason end_reason = EndReasonToProto(result.reason, stopped_by_shutdown);
  env_.metrics->RecordPlan(v1::EndReason_Name(end_reason), absl::Seconds(result.elapsed_s));
  // Built outside the lock (the display path and the tree can be large): the
  // plan thread pays for it, and gRPC's threads never wait for it.
  absl::StatusOr<v1::PlanUpdate> final_update =
      FinalUpdateToProto(result, end_reason, spec_.params, spec_.display_step_m,
                         spec_.options.record_tree, spec_.frame.get());
  // A planner's best trajectory always converts; in a release build a
  // failure still ends the call, with INTERNAL, instead of a final message
  // without its trajectory.
  RISKPLAN_DCHECK(final_update.ok());
  Step step;
  {
    absl::MutexLock lock(&mu_);
    log_detail_ = absl::StrFormat(
        "end_reason=%s iterations=%d tree_size=%d improvements=%d risk=%.9g planner_s=%.3f",
        v1::EndReason_Name(end_reason), result.iterations, result.tree_size, improvements_,
        result.best.has_value() ? result.best->risk : -1.0, result.elapsed_s);
    if (final_update.ok()) {
      final_update->set_improvements(improvements_);
      *final_update->mutable_wind() = spec_.wind;
      step = state_.EndPlan(*std::move(final_update), absl::Now());
      TakeWriteLocked(&step);
    } else {
      step = state_.RequestFinish(ToGrpcStatus(final_update.status()));
    }
  }
  if (!final_update.ok()) LogUpdateFailed("final", final_update.status());
  Perform(step);
}

void PlanCall::OnImprovement(const PlanImprovement& improvement) {
  // Built outside the lock: the planner thread pays for it, not gRPC's.
  absl::StatusOr<v1::PlanUpdate> update =
      ImprovementToProto(improvement, spec_.params, spec_.display_step_m, spec_.frame.get());
  // Never fails for a planner's output; in a release build the update is
  // dropped (a later improvement or the final message carries a newer one).
  RISKPLAN_DCHECK(update.ok());
  Step step;
  {
    absl::MutexLock lock(&mu_);
    ++improvements_;
    if (update.ok()) {
      update->set_improvements(improvements_);
      *update->mutable_wind() = spec_.wind;
      step = state_.Offer(*std::move(update), absl::Now());
      TakeWriteLocked(&step);
    }
  }
  if (!update.ok()) {
    LogUpdateFailed("improvement", update.status());
    return;
  }
  Perform(step);
}

void PlanCall::OnTimer() {
  Step step;
  {
    absl::MutexLock lock(&mu_);
    step = state_.Poll(absl::Now());
    TakeWriteLocked(&step);
  }
  Perform(step);
}

void PlanCall::TakeWriteLocked(Step* step) {
  if (!step->write.has_value()) return;
  // Numbered here, at the moment it is sent, so that sequence numbers have
  // no gaps however many updates the coalescer replaced.
  write_buffer_ = std::move(*step->write);
  write_buffer_.set_sequence(++sent_);
}

void PlanCall::Perform(const Step& step) {
  if (step.stop_planner) cancel_.Cancel();
  if (step.wake_at.has_value()) {
    // The timer's reference keeps the call alive until the wake-up has run,
    // even if gRPC is done with it by then (OnTimer then does nothing).
    env_.timer->Schedule(*step.wake_at, [self = shared_from_this()] { self->OnTimer(); });
  }
  if (step.write.has_value()) {
    if (absl::Status s = SerializeWrite(); !s.ok()) {
      // Cannot happen for a message under the send limit; the write is
      // replaced by its failure so that the state still sees it end.
      LogUpdateFailed("serialise", s);
      OnWriteDone(false);
      return;
    }
    StartWrite(&raw_write_);
  } else if (step.finish.has_value()) {
    Finish(*step.finish);
  }
}

absl::Status PlanCall::SerializeWrite() { return SerializeMessage(write_buffer_, &raw_write_); }

void PlanCall::FinishWith(const grpc::Status& status) {
  Step step;
  {
    absl::MutexLock lock(&mu_);
    step = state_.RequestFinish(status);
  }
  Perform(step);
}

void PlanCall::LogUpdateFailed(std::string_view which, const absl::Status& status) const {
  LogEvent("plan_update_failed",
           absl::StrFormat("update=%s peer=%s map=%s algorithm=%s: %s", which, peer_,
                           spec_.map ? spec_.map->name() : "",
                           PlannerAlgorithmName(spec_.algorithm), status.message()));
}

void PlanCall::OnWriteDone(bool ok) {
  // Finish, started below, may let OnDone run on another thread and drop
  // gRPC's reference while this reaction is still running: hold the call
  // until it returns.
  std::shared_ptr<PlanCall> keep = shared_from_this();
  Step step;
  {
    absl::MutexLock lock(&mu_);
    // A failed write means the client is gone: the state stops the planner
    // and finishes the call once Run is done with it.
    step = ok ? state_.WriteDone(absl::Now()) : state_.WriteFailed();
    TakeWriteLocked(&step);
  }
  Perform(step);
}

void PlanCall::OnCancel() {
  // Read outside the lock: ctx_ is valid until OnDone, which runs after this.
  const bool deadline_passed = ctx_->deadline() <= std::chrono::system_clock::now();
  Step step;
  {
    absl::MutexLock lock(&mu_);
    step = state_.Cancel(deadline_passed ? CancelCause::kDeadline : CancelCause::kClient);
  }
  Perform(step);
}

void PlanCall::OnDone() {
  grpc::Status status;
  std::string detail;
  int64_t sent = 0, replaced = 0;
  {
    absl::MutexLock lock(&mu_);
    // gRPC calls OnDone only after Finish: the state must have got there.
    RISKPLAN_DCHECK(state_.phase() == PlanCallPhase::kFinished);
    status = state_.ReportedStatus();
    detail = log_detail_;
    sent = static_cast<int64_t>(sent_);
    replaced = state_.replaced();
  }
  const absl::Duration duration = absl::Now() - started_;
  env_.metrics->RecordRpc("PlanTrajectory", status.error_code(), duration, caller_.label);
  env_.metrics->RecordUpdates(sent, replaced);
  if (!detail.empty()) detail += absl::StrFormat(" sent=%d replaced=%d", sent, replaced);
  LogRpc({.method = "PlanTrajectory",
          .status = status,
          .duration = duration,
          .peer = peer_,
          .identity = caller_.identity,
          .map = spec_.map ? spec_.map->name() : "",
          .detail = detail});
  // Counted down only after the log line: the drain waits for open calls, so
  // a server that exits has written every call's line.
  if (env_.open_calls != nullptr) env_.open_calls->Done();
  // Drops gRPC's reference last: this may destroy the call.
  std::shared_ptr<PlanCall> last = std::move(self_);
}

}  // namespace riskplan::server
