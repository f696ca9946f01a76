// PlannerService: riskplan.v1.Planner on gRPC's callback API.
//
// Threading: handlers run on gRPC's threads and only validate, look up and
// dispatch. Planning runs on the plan pool (--plan_threads), risk evaluation,
// map-layer downsampling and risk layers on the evaluation pool
// (--eval_threads); ListMaps and Ping answer inline. See
// docs/architecture.md.
//
// Shutdown: StartDraining() makes every new call fail with UNAVAILABLE;
// ActivePlans lets the caller wait for running plans and stop them.
#ifndef RISKPLAN_SERVER_PLANNER_SERVICE_H_
#define RISKPLAN_SERVER_PLANNER_SERVICE_H_

#include <atomic>
#include <cstddef>
#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "accel/risk_engine.h"
#include "core/base/cancellation.h"
#include "grpcpp/grpcpp.h"
#include "riskplan/v1/planner.grpc.pb.h"
#include "server/security/auth.h"
#include "server/models/feasibility_cache.h"
#include "server/fleet/fleet_scheduler.h"
#include "server/flight/flight_call.h"
#include "server/models/goal_tree_cache.h"
#include "server/models/map_registry.h"
#include "server/observability/metrics.h"
#include "server/models/model_cache.h"
#include "server/plan/open_calls.h"
#include "server/plan/plan_call.h"
#include "server/api/request_validation.h"
#include "server/plan/thread_pool.h"
#include "server/plan/timer_queue.h"

namespace riskplan::server {

struct ServiceOptions {
  RequestLimits limits;
  int plan_threads = 2;            // planners running at once
  int max_running_plans = 4;       // admitted plans (planning or queued); more: RESOURCE_EXHAUSTED
  // PlanFleet: mission groups planning at once (each also takes one of
  // max_running_plans), and missions admitted at once over every fleet
  // (queued or planning; a fleet that does not fit: RESOURCE_EXHAUSTED).
  int fleet_plan_slots = 2;
  int64_t max_admitted_missions = 1024;
  int eval_threads = 2;            // EvaluateRisk and GetMapLayer workers
  size_t max_queued_evals = 1024;  // waiting evaluations; more: RESOURCE_EXHAUSTED
  size_t max_cached_checkers = 8;  // two-tier feasibility checkers kept (EvaluateRisk.two_tier)
  // PlanFleet's goal trees kept across requests (server/models/goal_tree_cache.h),
  // bytes by GoalTreeCache::TreeBytes; 0: none, each shared group grows its
  // tree from the goal.
  size_t goal_tree_cache_bytes = 0;
  // Computes every risk batch of plans and evaluations (CPU workers, FPGA
  // boards); null: each call computes its own on its thread. Not owned; must
  // outlive the service.
  accel::RiskEngine* engine = nullptr;
  // Decides who may call what (server/security/auth.h); null: everyone may call
  // everything.
  std::shared_ptr<Authorizer> authorizer;
  // Fly sessions' bounds (zones, reports, replanning budget).
  FlightLimits flight_limits;
};

// The work of an EvaluateRisk call once ValidateEvaluateRequest has passed
// (run on the evaluation pool): the model of the spec's map and parameters
// from `models`, the pieces and the sample limits, the evaluation (on
// `engine`, or on the calling thread when it is null), then the two-tier check
// with a checker from `checkers`, into `response`. Cancelled once `stop` is
// reached. Public so that a fuzz target runs exactly what the service runs.
absl::Status RunEvaluation(RiskModelCache& models, FeasibilityCache& checkers,
                           accel::RiskEngine* engine, const RequestLimits& limits,
                           const EvaluateSpec& spec, const StopCondition& stop,
                           v1::EvaluateRiskResponse* response);

// riskplan.v1.Planner with every method raw (server/api/message_codec.h says
// why): the service parses each request and serialises each response itself.
// Fly, a bidirectional stream of small messages, is the one typed method.
using RawPlannerService = v1::Planner::WithRawCallbackMethod_PlanTrajectory<
    v1::Planner::WithRawCallbackMethod_PlanFleet<v1::Planner::WithRawCallbackMethod_EvaluateRisk<
        v1::Planner::WithRawCallbackMethod_ListMaps<v1::Planner::WithRawCallbackMethod_GetMapLayer<
            v1::Planner::WithRawCallbackMethod_GetRiskLayer<v1::Planner::WithRawCallbackMethod_Ping<
                v1::Planner::WithCallbackMethod_Fly<v1::Planner::Service>>>>>>>>;

class PlannerService final : public RawPlannerService {
 public:
  // `maps`, `models` and `metrics` must outlive the service.
  PlannerService(const MapRegistry& maps, RiskModelCache& models, ServerMetrics& metrics,
                 const ServiceOptions& options);
  // Waits for queued and running work. Call after the gRPC server has shut
  // down (no handler may run any more).
  ~PlannerService() override;

  // Each parses its request (INVALID_ARGUMENT when the bytes are not the
  // method's request message), then serves it.
  grpc::ServerWriteReactor<grpc::ByteBuffer>* PlanTrajectory(
      grpc::CallbackServerContext* ctx, const grpc::ByteBuffer* request) override;
  grpc::ServerWriteReactor<grpc::ByteBuffer>* PlanFleet(grpc::CallbackServerContext* ctx,
                                                        const grpc::ByteBuffer* request) override;
  // An in-flight session (server/flight/flight_call.h): the caller, the
  // drain, admission (one of --max_running_plans' slots for the session's
  // life); the opening is validated by the session itself.
  grpc::ServerBidiReactor<v1::FlightInput, v1::FlightOutput>* Fly(
      grpc::CallbackServerContext* ctx) override;
  grpc::ServerUnaryReactor* EvaluateRisk(grpc::CallbackServerContext* ctx,
                                         const grpc::ByteBuffer* request,
                                         grpc::ByteBuffer* response) override;
  grpc::ServerUnaryReactor* ListMaps(grpc::CallbackServerContext* ctx,
                                     const grpc::ByteBuffer* request,
                                     grpc::ByteBuffer* response) override;
  grpc::ServerUnaryReactor* GetMapLayer(grpc::CallbackServerContext* ctx,
                                        const grpc::ByteBuffer* request,
                                        grpc::ByteBuffer* response) override;
  grpc::ServerUnaryReactor* GetRiskLayer(grpc::CallbackServerContext* ctx,
                                         const grpc::ByteBuffer* request,
                                         grpc::ByteBuffer* response) override;
  grpc::ServerUnaryReactor* Ping(grpc::CallbackServerContext* ctx, const grpc::ByteBuffer* request,
                                 grpc::ByteBuffer* response) override;

  // From now on every new call gets UNAVAILABLE, and fleet missions still
  // waiting for a plan slot end at once (end reason SHUTDOWN). Thread-safe.
  void StartDraining() {
    draining_.store(true);
    fleet_.StopQueued();
  }
  bool draining() const { return draining_.load(); }
  // Stops the evaluations queued and running (they end with UNAVAILABLE)
  // and the model builds: the drain's last step before gRPC shuts down, so
  // that no worker is left computing for a call that cannot be answered.
  // Thread-safe.
  void StopEvaluations();

  ActivePlans& active_plans() { return active_; }
  // Calls of this service gRPC has not finished with (plans, evaluations...).
  const OpenCalls& open_calls() const { return open_calls_; }
  // The two-tier checkers of EvaluateRisk (for the cache metrics).
  std::shared_ptr<const FeasibilityCache> checkers() const { return checkers_; }
  // PlanFleet's goal trees (for the cache metrics); null when the cache is off.
  const GoalTreeCache* goal_trees() const { return goal_trees_.get(); }

 private:
  // What the unary handlers share, in the order every one takes it (the
  // codes and messages the same for all): a reactor for `method`, the
  // caller's token and role, the drain, the request's parsing; then
  // serve(request, call) validates and answers or queues. Defined in
  // planner_service.cc, the only user.
  template <typename Request, typename Response, typename Serve>
  grpc::ServerUnaryReactor* ServeUnary(const char* method, grpc::CallbackServerContext* ctx,
                                       const grpc::ByteBuffer* raw_request,
                                       grpc::ByteBuffer* raw_response, Serve serve);
  // Queues work(stop, call->response()) on the evaluation pool, `stop`
  // being the call's cancellation or StopEvaluations; the call ends with
  // work's status, or UNAVAILABLE when the drain stopped it, logged with
  // `map`. False when the queue is full (the call is not ended then).
  template <typename Call, typename Work>
  bool QueueEvaluation(Call* call, const char* method, std::string map, Work work);
  // A validated request's work, work(spec, stop, response), through
  // QueueEvaluation; `spec`'s error ends the call at once, and a full queue
  // with EvaluationsWaiting, each logged with `request_map`.
  template <typename Call, typename Spec, typename Work>
  void QueueValidated(Call* call, const char* method, const std::string& request_map,
                      absl::StatusOr<Spec> spec, Work work);
  // RESOURCE_EXHAUSTED: --max_queued_evals evaluations are waiting.
  grpc::Status EvaluationsWaiting() const;

  const MapRegistry& maps_;
  RiskModelCache& models_;
  ServerMetrics& metrics_;
  const ServiceOptions options_;
  const std::shared_ptr<Authorizer> authorizer_;  // never null
  const std::shared_ptr<FeasibilityCache> checkers_;
  // Before fleet_, which plans with it.
  const std::unique_ptr<GoalTreeCache> goal_trees_;
  v1::ListMapsResponse map_list_;  // built once
  std::atomic<bool> draining_{false};
  CancellationToken stop_evaluations_;  // cancelled by StopEvaluations
  ActivePlans active_;
  OpenCalls open_calls_;
  // Its groups plan on plan_pool_, which is destroyed first (it runs the
  // tasks still queued, and they use fleet_).
  FleetScheduler fleet_;
  // Declared last: destroyed first, so queued tasks run while everything they
  // use is still alive.
  TimerQueue timer_;
  ThreadPool eval_pool_;
  ThreadPool plan_pool_;
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_PLANNER_SERVICE_H_
