#include "server/planner_service.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/time/clock.h"
#include "accel/kernel_evaluator.h"
#include "core/flight/trajectory.h"
#include "core/risk/risk_layer.h"
#include "server/api/message_codec.h"
#include "server/api/proto_convert.h"
#include "server/api/risk_layer_request.h"
#include "server/api/status_util.h"
#include "server/observability/rpc_log.h"

namespace riskplan::server {
namespace {

const grpc::Status kDraining(grpc::StatusCode::UNAVAILABLE,
                             "riskplan-server is shutting down; retry on another replica");

// The reactor of every unary RPC, holding its typed response until it is
// serialised into gRPC's raw one. Complete() logs the RPC and records its
// metrics before finishing it, so a client that has its answer also finds
// the log line written. Owned by gRPC from the handler's return to OnDone,
// where it deletes itself; OpenCalls counts it for as long (the drain waits
// for that count, see open_calls.h).
template <typename Response>
class UnaryCall final : public grpc::ServerUnaryReactor {
 public:
  UnaryCall(const char* method, grpc::CallbackServerContext* ctx, ServerMetrics* metrics,
            OpenCalls* open_calls, grpc::ByteBuffer* raw_response)
      : method_(method),
        started_(absl::Now()),
        ctx_(ctx),
        metrics_(metrics),
        open_calls_(open_calls),
        raw_response_(raw_response) {
    open_calls_->Opened();
  }

  // The response Complete(OK) sends. Written by one thread at a time (the
  // handler, then the task it queues), until Complete.
  Response* response() { return &response_; }
  // Who called (for the log line and the metrics); set by the handler
  // before Complete.
  void set_caller(Caller caller) { caller_ = std::move(caller); }
  // Cancelled when the client cancels the call or its deadline passes.
  const CancellationToken& cancelled() const { return cancelled_; }

  // Ends the call, from any thread. Only the first call counts: Guarded
  // may end a call whose work threw after it had ended it.
  void Complete(grpc::Status status, std::string map = "") {
    if (completed_.exchange(true)) return;
    try {
      if (status.ok()) {
        if (absl::Status s = SerializeMessage(response_, raw_response_); !s.ok()) {
          status = ToGrpcStatus(s);
        }
      }
    } catch (const std::exception& e) {
      status = ToGrpcStatus(StatusFromException(e, method_));
    }
    // The call ends even when it cannot be logged (out of memory).
    try {
      const absl::Duration duration = absl::Now() - started_;
      metrics_->RecordRpc(method_, status.error_code(), duration, caller_.label);
      LogRpc({.method = method_,
              .status = status,
              .duration = duration,
              .peer = ctx_->peer(),
              .identity = caller_.identity,
              .map = std::move(map),
              .detail = ""});
    } catch (const std::exception&) {
    }
    Finish(status);
  }

  void OnCancel() override { cancelled_.Cancel(); }

  void OnDone() override {
    open_calls_->Done();
    delete this;
  }

 private:
  const char* const method_;
  const absl::Time started_;
  grpc::CallbackServerContext* const ctx_;
  ServerMetrics* const metrics_;
  OpenCalls* const open_calls_;
  grpc::ByteBuffer* const raw_response_;  // gRPC's, valid until OnDone
  Response response_;
  Caller caller_;
  CancellationToken cancelled_;
  std::atomic<bool> completed_{false};
};

// Checks that the caller may call `method` (server/security/auth.h), records who it
// is on `call`, and ends the call with UNAUTHENTICATED or PERMISSION_DENIED
// if not: false then.
template <typename Call>
bool Authorize(Authorizer& authorizer, grpc::CallbackServerContext* ctx, const char* method,
               Call* call) {
  Caller caller;
  grpc::Status status = authorizer.Check(*ctx, method, &caller);
  call->set_caller(std::move(caller));
  if (status.ok()) return true;
  call->Complete(status);
  return false;
}

// Runs `body` (a handler's or a task's work for `call`), ending the call with
// StatusFromException if it throws: no exception leaves a request's thread.
// (If the call was already ended, Complete ignores the second end.)
template <typename Call, typename Body>
void Guarded(Call* call, const char* what, const std::string& map, Body body) {
  try {
    body();
  } catch (const std::exception& e) {
    call->Complete(ToGrpcStatus(StatusFromException(e, what)), map);
  }
}

// The length of a trajectory's pieces, once each has a finite one and the
// sum of their samples passed CheckSampleCount. `waypoints`: the pieces came
// from EvaluateSpec.waypoints (else from its polyline), for the messages.
absl::StatusOr<double> CheckedLength(const std::vector<TrajectoryPiece>& pieces, bool waypoints,
                                     double sample_step_m, bool include_samples,
                                     const RequestLimits& limits) {
  int64_t samples = 0;
  double length_m = 0.0;
  for (size_t i = 0; i < pieces.size(); ++i) {
    const TrajectoryPiece& piece = pieces[i];
    // Finite coordinates far apart overflow the geometry: such a piece has
    // no length to report, let alone samples.
    if (!std::isfinite(piece.Length())) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "%s: the piece from point %d to point %d has length %g m; the points are too far apart "
          "to be flown",
          waypoints ? "waypoints.poses" : "polyline.points", i, i + 1, piece.Length()));
    }
    // Saturates at kMaxPartCount, so no sum of counts can wrap past the limit.
    samples += std::min(PartCount(piece.Length(), sample_step_m), kMaxPartCount - samples);
    length_m += piece.Length();
  }
  if (absl::Status s = CheckSampleCount(samples, length_m, sample_step_m, include_samples, limits);
      !s.ok()) {
    return s;
  }
  return length_m;
}

// EvaluateRiskResponse.path: the pieces sampled every spec.path_spacing_m,
// with each pose's configuration risk through `evaluator` (the one that
// evaluated the trajectory), in batches of kEvaluationBatch so that `stop`
// is polled between them.
absl::Status AddPath(const RiskModel& model, const std::vector<TrajectoryPiece>& pieces,
                     double length_m, const EvaluateSpec& spec, const RequestLimits& limits,
                     RiskEvaluator& evaluator, const StopCondition& stop,
                     v1::EvaluateRiskResponse* response) {
  // Counted before it is sampled: the path's poses, their risks and their
  // WGS84 forms are all bounded by --max_response_samples.
  if (absl::Status s = CheckPathCount(length_m, spec.path_spacing_m, limits); !s.ok()) return s;
  const std::vector<PathPose> path =
      SamplePath(pieces, spec.path_spacing_m, static_cast<size_t>(limits.max_response_samples));
  std::vector<Pose> poses;
  poses.reserve(path.size());
  for (const PathPose& p : path) poses.push_back(p.pose);
  std::vector<ConfigurationRisk> risks(poses.size());
  for (size_t begin = 0; begin < poses.size(); begin += kEvaluationBatch) {
    if (stop.Reached()) return absl::CancelledError("the evaluation was stopped");
    const size_t n = std::min(kEvaluationBatch, poses.size() - begin);
    if (absl::Status s =
            evaluator.EvaluateBatch(model, std::span<const Pose>(poses).subspan(begin, n),
                                    std::span<ConfigurationRisk>(risks).subspan(begin, n));
        !s.ok()) {
      return s;
    }
  }
  PathToProto(path, risks, *spec.map, model.params(), spec.frame.get(), response);
  return absl::OkStatus();
}

}  // namespace

// On the evaluation pool: building a model and evaluating a long trajectory
// can take seconds. `stop` is the call's cancellation or the server's drain.
absl::Status RunEvaluation(RiskModelCache& models, FeasibilityCache& checkers,
                           accel::RiskEngine* engine, const RequestLimits& limits,
                           const EvaluateSpec& spec, const StopCondition& stop,
                           v1::EvaluateRiskResponse* response) {
  if (stop.Reached()) return absl::CancelledError("the evaluation was stopped before it started");
  absl::StatusOr<std::shared_ptr<const RiskModel>> model = models.Get(*spec.map, spec.params);
  if (!model.ok()) return InField("model_params", model.status());
  const ModelParams& params = (*model)->params();
  absl::StatusOr<std::vector<TrajectoryPiece>> pieces =
      spec.polyline.empty() ? PiecesFromWaypoints(spec.waypoints, params, limits.max_waypoints)
                            : PiecesFromPolyline(spec.polyline, limits.max_waypoints);
  if (!pieces.ok()) return pieces.status();
  absl::StatusOr<double> length_m = CheckedLength(
      *pieces, spec.polyline.empty(), params.sample_step_m, spec.include_samples, limits);
  if (!length_m.ok()) return length_m.status();
  // Without an engine: accel's exact kernel on this thread (RiskModel::Evaluate bit for bit).
  // With one, a batch stops waiting for boards once `stop` is reached (its
  // remaining chunks are computed here, RiskEngine::Evaluate).
  std::unique_ptr<RiskEvaluator> engine_evaluator =
      engine != nullptr ? engine->NewEvaluator(stop) : nullptr;
  RiskEvaluator* evaluator =
      engine_evaluator != nullptr ? engine_evaluator.get() : &accel::ThreadKernelEvaluator();
  absl::StatusOr<TrajectoryEvaluation> evaluation = EvaluateTrajectory(
      **model, *pieces, EvaluationOptions{.keep_samples = spec.include_samples}, evaluator, stop);
  if (!evaluation.ok()) return evaluation.status();
  // Every reported number is finite, or the request is refused: the
  // parameter ranges are meant to guarantee it, and this says so if not.
  if (!std::isfinite(evaluation->risk) || !std::isfinite(evaluation->length_m)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "model_params: the trajectory's risk is %g and its length %g m with these parameters; "
        "both must be finite",
        evaluation->risk, evaluation->length_m));
  }
  EvaluationToProto(*evaluation, params, spec.include_samples, spec.frame.get(), response);
  *response->mutable_wind() = spec.wind;
  if (spec.two_tier.has_value()) {
    // Bounded like the evaluation: the cells visited grow with the length,
    // which CheckSampleCount has capped.
    std::shared_ptr<const SharedFeasibility> feasibility = checkers.Get(*model, *spec.two_tier);
    FeasibilityToProto(feasibility->checker.CheckTrajectory(*pieces), spec.frame.get(),
                       response->mutable_two_tier());
  }
  if (spec.path_spacing_m > 0.0) {
    return AddPath(**model, *pieces, *length_m, spec, limits, *evaluator, stop, response);
  }
  return absl::OkStatus();
}

// The risk layer of a validated request (on the evaluation pool), stopped
// once `stop` is reached.
absl::Status ComputeLayer(RiskModelCache& models, const RiskLayerSpec& spec,
                          const StopCondition& stop, v1::GetRiskLayerResponse* response) {
  if (stop.Reached()) return absl::CancelledError("the risk layer was stopped before it started");
  absl::StatusOr<std::shared_ptr<const RiskModel>> model = models.Get(*spec.map, spec.params);
  if (!model.ok()) return InField("model_params", model.status());
  RiskLayerOptions options = spec.options;
  options.stop = stop;
  absl::StatusOr<RiskLayer> layer = ComputeRiskLayer(**model, options);
  if (!layer.ok()) return layer.status();
  *response = RiskLayerToProto(*layer, *spec.map, options, spec.frame.get());
  *response->mutable_wind() = spec.wind;
  return absl::OkStatus();
}

PlannerService::PlannerService(const MapRegistry& maps, RiskModelCache& models,
                               ServerMetrics& metrics, const ServiceOptions& options)
    : maps_(maps),
      models_(models),
      metrics_(metrics),
      options_(options),
      authorizer_(options.authorizer != nullptr ? options.authorizer
                                                : std::make_shared<Authorizer>(nullptr)),
      checkers_(std::make_shared<FeasibilityCache>(options.max_cached_checkers)),
      goal_trees_(options.goal_tree_cache_bytes > 0
                      ? std::make_unique<GoalTreeCache>(options.goal_tree_cache_bytes)
                      : nullptr),
      active_(options.max_running_plans),
      fleet_(FleetEnv{.models = &models_,
                      .metrics = &metrics_,
                      .active = &active_,
                      .pool = &plan_pool_,
                      .engine = options.engine,
                      .goal_trees = goal_trees_.get()},
             options.fleet_plan_slots, options.max_admitted_missions),
      eval_pool_(options.eval_threads, options.max_queued_evals),
      plan_pool_(options.plan_threads) {
  // Every plan slot freed (a plan's or a fleet group's) may start a waiting
  // fleet group.
  active_.SetReleaseListener([this] { fleet_.Pump(); });
  // The maps never change while the server runs: ListMaps's answer is built
  // once (MapInfoFromMap scans the terrain) and copied for every call.
  for (const std::shared_ptr<const RiskMap>& map : maps_.maps()) {
    *map_list_.add_maps() = MapInfoFromMap(*map, maps_.Frame(map->name()).get());
    metrics_.SetMapMemory(map->name(), static_cast<double>(map->MemoryBytes()));
  }
}

// The members do the waiting: the plan pool, then the evaluation pool, run
// every task still queued (each ends its call), then the timer drops its
// wake-ups. Declared last, they are destroyed first, while everything their
// tasks use is still alive (planner_service.h).
PlannerService::~PlannerService() = default;

void PlannerService::StopEvaluations() {
  stop_evaluations_.Cancel();
  models_.StopBuilds();
}

grpc::ServerWriteReactor<grpc::ByteBuffer>* PlannerService::PlanTrajectory(
    grpc::CallbackServerContext* ctx, const grpc::ByteBuffer* raw_request) {
  // Every check comes before admission, so a request that will fail never
  // holds a slot: the caller's token and role first (an unauthorised caller
  // learns nothing of the server's state), then a draining server refuses,
  // then parsing, validation, the endpoints (when the model is ready),
  // admission and the plan pool.
  Caller caller;
  const grpc::Status authorized = authorizer_->Check(*ctx, "PlanTrajectory", &caller);
  v1::PlanRequest request;
  absl::Status parsed = authorized.ok() ? ParseRequest(*raw_request, &request) : absl::OkStatus();
  absl::StatusOr<PlanSpec> spec =
      // Not parsed nor validated for a refused caller; `authorized` is the
      // status the call ends with.
      !authorized.ok() ? absl::PermissionDeniedError("not authorized")
      : parsed.ok()    ? ValidatePlanRequest(request, maps_, options_.limits)
                       : parsed;
  // A call that fails before admission still goes through a PlanCall, so
  // that every PlanTrajectory is logged and counted the same way.
  PlanSpec call_spec;
  if (spec.ok()) call_spec = *spec;
  std::shared_ptr<PlanCall> call = PlanCall::Create(PlanCallEnv{.models = &models_,
                                                                .metrics = &metrics_,
                                                                .timer = &timer_,
                                                                .active = &active_,
                                                                .engine = options_.engine,
                                                                .open_calls = &open_calls_},
                                                    ctx, std::move(call_spec), std::move(caller));
  if (!authorized.ok()) {
    call->Reject(authorized);
    return call.get();
  }
  if (draining()) {
    call->Reject(kDraining);
    return call.get();
  }
  if (!spec.ok()) {
    call->Reject(ToGrpcStatus(spec.status()));
    return call.get();
  }
  if (absl::Status s = call->CheckEndpointsIfModelReady(); !s.ok()) {
    call->Reject(ToGrpcStatus(s));
    return call.get();
  }
  if (!active_.TryAdmit(call)) {
    call->Reject(
        grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                     absl::StrFormat("riskplan-server is running its maximum of %d plans "
                                     "(--max_running_plans); retry later or on another replica",
                                     active_.max_running())));
    return call.get();
  }
  // Recorded before the task is queued: Run() may start at once, and it
  // releases what was admitted (PlanCall::Run checks both).
  metrics_.PlanAdmitted(ServerMetrics::PlanKind::kTrajectory);
  // The pool's queue is unbounded (admission bounds it); it refuses only
  // while it is being destroyed.
  if (!plan_pool_.TrySubmit([call] { call->Run(); })) {
    active_.Release(call.get());
    metrics_.PlanReleased(ServerMetrics::PlanKind::kTrajectory);
    call->Reject(kDraining);
  }
  return call.get();
}

grpc::ServerBidiReactor<v1::FlightInput, v1::FlightOutput>* PlannerService::Fly(
    grpc::CallbackServerContext* ctx) {
  Caller caller;
  const grpc::Status authorized = authorizer_->Check(*ctx, "Fly", &caller);
  std::shared_ptr<FlightCall> call = FlightCall::Create(FlightCallEnv{
      .flight = FlightEnv{.maps = &maps_,
                          .models = &models_,
                          .request_limits = options_.limits,
                          .limits = options_.flight_limits},
      .active = &active_,
      .pool = &plan_pool_,
      .metrics = &metrics_,
      .open_calls = &open_calls_}, ctx, caller);
  if (!authorized.ok()) {
    call->Reject(authorized);
    return call.get();
  }
  if (draining()) {
    call->Reject(kDraining);
    return call.get();
  }
  if (!active_.TryAdmit(call)) {
    call->Reject(grpc::Status(
        grpc::StatusCode::RESOURCE_EXHAUSTED,
        absl::StrFormat("riskplan-server is running its maximum of %d plans and sessions "
                        "(--max_running_plans); retry later or on another replica",
                        active_.max_running())));
    return call.get();
  }
  metrics_.PlanAdmitted(ServerMetrics::PlanKind::kTrajectory);
  call->Start();
  return call.get();
}

grpc::ServerWriteReactor<grpc::ByteBuffer>* PlannerService::PlanFleet(
    grpc::CallbackServerContext* ctx, const grpc::ByteBuffer* raw_request) {
  // PlanTrajectory's order: the caller, the drain, the request, then
  // admission (of the missions, all or none), before any mission plans.
  Caller caller;
  const grpc::Status authorized = authorizer_->Check(*ctx, "PlanFleet", &caller);
  std::shared_ptr<FleetCall> call = FleetCall::Create(ctx, &metrics_, &open_calls_, caller);
  if (!authorized.ok()) {
    call->Reject(authorized);
    return call.get();
  }
  if (draining()) {
    call->Reject(kDraining);
    return call.get();
  }
  v1::FleetRequest request;
  if (absl::Status s = ParseRequest(*raw_request, &request); !s.ok()) {
    call->Reject(ToGrpcStatus(s));
    return call.get();
  }
  absl::StatusOr<FleetSpec> spec = ValidateFleetRequest(request, maps_, options_.limits);
  if (!spec.ok()) {
    call->Reject(ToGrpcStatus(spec.status()));
    return call.get();
  }
  const int64_t missions = static_cast<int64_t>(spec->missions.size());
  if (!fleet_.TryAdmit(missions)) {
    call->Reject(grpc::Status(
        grpc::StatusCode::RESOURCE_EXHAUSTED,
        absl::StrFormat("riskplan-server cannot admit this fleet's %d missions: at most %d fleet "
                        "missions are admitted at once (--max_admitted_missions); retry later or "
                        "on another replica",
                        missions, fleet_.max_admitted_missions())));
    return call.get();
  }
  metrics_.RecordFleetMissionsAdmitted(missions);
  auto shared = std::make_shared<const FleetSpec>(*std::move(spec));
  const std::vector<MissionGroup> groups = GroupMissions(*shared);
  int64_t grouped = 0;
  for (const MissionGroup& g : groups) grouped += static_cast<int64_t>(g.missions.size());
  // The invalid missions end now (Start), and count no longer.
  fleet_.Unadmit(missions - grouped);
  // Fair share is between authenticated callers; without a token or a
  // client certificate, the request's tenant says who the fleet is for
  // (prefixed, so that it can never pass for an authenticated identity).
  const std::string identity =
      !caller.identity.empty() ? caller.identity : absl::StrCat("tenant:", shared->tenant);
  FleetCall* raw_call = call.get();
  call->Start(shared, static_cast<int>(groups.size()),
              [this, raw_call] { fleet_.DropQueued(raw_call); });
  fleet_.Enqueue(call, shared, groups, identity);
  return call.get();
}

template <typename Request, typename Response, typename Serve>
grpc::ServerUnaryReactor* PlannerService::ServeUnary(const char* method,
                                                     grpc::CallbackServerContext* ctx,
                                                     const grpc::ByteBuffer* raw_request,
                                                     grpc::ByteBuffer* raw_response, Serve serve) {
  auto* call = new UnaryCall<Response>(method, ctx, &metrics_, &open_calls_, raw_response);
  Guarded(call, method, "", [&] {
    // The caller's token and role first: an unauthorised caller learns
    // nothing of the server's state, not even that it drains.
    if (!Authorize(*authorizer_, ctx, method, call)) return;
    if (draining()) {
      call->Complete(kDraining);
      return;
    }
    Request request;
    if (absl::Status s = ParseRequest(*raw_request, &request); !s.ok()) {
      call->Complete(ToGrpcStatus(s));
      return;
    }
    serve(request, call);
  });
  return call;
}

template <typename Call, typename Work>
bool PlannerService::QueueEvaluation(Call* call, const char* method, std::string map, Work work) {
  // `call` (and its response) stay valid until the call is finished, and
  // `this` until every queued task has run (the pools are destroyed first).
  return eval_pool_.TrySubmit([this, call, method, map = std::move(map), work = std::move(work)] {
    Guarded(call, method, map, [&] {
      const StopCondition stop(&call->cancelled(), &stop_evaluations_);
      absl::Status status = work(stop, call->response());
      // Stopped: by the drain (the client may still be there to be told),
      // or by the client itself (who no longer listens).
      if (absl::IsCancelled(status) && stop_evaluations_.IsCancelled()) {
        call->Complete(kDraining, map);
        return;
      }
      call->Complete(ToGrpcStatus(status), map);
    });
  });
}

template <typename Call, typename Spec, typename Work>
void PlannerService::QueueValidated(Call* call, const char* method, const std::string& request_map,
                                    absl::StatusOr<Spec> spec, Work work) {
  if (!spec.ok()) {
    call->Complete(ToGrpcStatus(spec.status()), request_map);
    return;
  }
  std::string map = spec->map->name();
  const bool queued = QueueEvaluation(
      call, method, std::move(map),
      [spec = *std::move(spec), work = std::move(work)](const StopCondition& stop, auto* response) {
        return work(spec, stop, response);
      });
  if (!queued) call->Complete(EvaluationsWaiting(), request_map);
}

grpc::Status PlannerService::EvaluationsWaiting() const {
  return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                      absl::StrFormat("riskplan-server has %d evaluations waiting "
                                      "(--max_queued_evals); retry later",
                                      options_.max_queued_evals));
}

grpc::ServerUnaryReactor* PlannerService::EvaluateRisk(grpc::CallbackServerContext* ctx,
                                                       const grpc::ByteBuffer* raw_request,
                                                       grpc::ByteBuffer* raw_response) {
  return ServeUnary<v1::EvaluateRiskRequest, v1::EvaluateRiskResponse>(
      "EvaluateRisk", ctx, raw_request, raw_response,
      [this](const v1::EvaluateRiskRequest& request, auto* call) {
        QueueValidated(call, "EvaluateRisk", request.map(),
                       ValidateEvaluateRequest(request, maps_, options_.limits),
                       [this](const EvaluateSpec& spec, const StopCondition& stop,
                              v1::EvaluateRiskResponse* response) {
                         return RunEvaluation(models_, *checkers_, options_.engine, options_.limits,
                                              spec, stop, response);
                       });
      });
}

grpc::ServerUnaryReactor* PlannerService::ListMaps(grpc::CallbackServerContext* ctx,
                                                   const grpc::ByteBuffer* raw_request,
                                                   grpc::ByteBuffer* raw_response) {
  return ServeUnary<v1::ListMapsRequest, v1::ListMapsResponse>(
      "ListMaps", ctx, raw_request, raw_response, [this](const v1::ListMapsRequest&, auto* call) {
        *call->response() = map_list_;
        call->Complete(grpc::Status::OK);
      });
}

grpc::ServerUnaryReactor* PlannerService::GetMapLayer(grpc::CallbackServerContext* ctx,
                                                      const grpc::ByteBuffer* raw_request,
                                                      grpc::ByteBuffer* raw_response) {
  return ServeUnary<v1::GetMapLayerRequest, v1::GetMapLayerResponse>(
      "GetMapLayer", ctx, raw_request, raw_response,
      [this](const v1::GetMapLayerRequest& request, auto* call) {
        absl::StatusOr<std::shared_ptr<const RiskMap>> map = FindMap(maps_, request.map());
        if (!map.ok()) {
          call->Complete(ToGrpcStatus(map.status()), request.map());
          return;
        }
        const v1::MapLayer layer = request.layer();
        if (layer != v1::POPULATION_DENSITY && layer != v1::SHELTER && layer != v1::TERRAIN &&
            layer != v1::NO_FLY) {
          call->Complete(
              grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                           absl::StrFormat("layer has value %d; it must be POPULATION_DENSITY (1), "
                                           "SHELTER (2), TERRAIN (3) or NO_FLY (4)",
                                           static_cast<int>(layer))),
              request.map());
          return;
        }
        // Bounded so that the response stays at most 4096 x 4096 floats (64
        // MiB, the server's send limit); 512 by default, enough for a picture.
        int max_side = request.max_side_cells();
        if (max_side == 0) max_side = 512;
        if (max_side < 1 || max_side > 4096) {
          call->Complete(grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                                      absl::StrFormat("max_side_cells has value %d; it must be in "
                                                      "[1, 4096] (0: 512)",
                                                      request.max_side_cells())),
                         request.map());
          return;
        }
        // Downsampling is not stopped (it reads the layer once, quickly).
        const bool queued = QueueEvaluation(
            call, "GetMapLayer", (*map)->name(),
            [map = *map, layer, max_side](const StopCondition&, v1::GetMapLayerResponse* response) {
              *response = DownsampleLayer(*map, layer, max_side);
              return absl::OkStatus();
            });
        if (!queued) {
          call->Complete(EvaluationsWaiting(), request.map());
        }
      });
}

grpc::ServerUnaryReactor* PlannerService::GetRiskLayer(grpc::CallbackServerContext* ctx,
                                                       const grpc::ByteBuffer* raw_request,
                                                       grpc::ByteBuffer* raw_response) {
  return ServeUnary<v1::GetRiskLayerRequest, v1::GetRiskLayerResponse>(
      "GetRiskLayer", ctx, raw_request, raw_response,
      [this](const v1::GetRiskLayerRequest& request, auto* call) {
        // Every refusal, the layer's size above all, comes before the queue.
        QueueValidated(call, "GetRiskLayer", request.map(),
                       ValidateRiskLayerRequest(request, maps_, options_.limits),
                       [this](const RiskLayerSpec& spec, const StopCondition& stop,
                              v1::GetRiskLayerResponse* response) {
                         return ComputeLayer(models_, spec, stop, response);
                       });
      });
}

grpc::ServerUnaryReactor* PlannerService::Ping(grpc::CallbackServerContext* ctx,
                                               const grpc::ByteBuffer* raw_request,
                                               grpc::ByteBuffer* raw_response) {
  // Answered inline: there is nothing to compute, and a Ping that queued
  // behind evaluations would say nothing about the server's liveness.
  return ServeUnary<v1::PingRequest, v1::PingResponse>(
      "Ping", ctx, raw_request, raw_response,
      [](const v1::PingRequest&, auto* call) { call->Complete(grpc::Status::OK); });
}

}  // namespace riskplan::server
