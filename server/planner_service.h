// PlannerService: riskplan.v1.Planner on gRPC's callback API.
//
// Threading: handlers run on gRPC's threads and only validate, look up and
// dispatch. Planning runs on the plan pool (--plan_threads), risk evaluation
// and map-layer downsampling on the evaluation pool (--eval_threads); ListMaps
// and Ping answer inline. See docs/architecture.md.
//
// Shutdown: StartDraining() makes every new call fail with UNAVAILABLE;
// ActivePlans lets the caller wait for running plans and stop them.
#ifndef RISKPLAN_SERVER_PLANNER_SERVICE_H_
#define RISKPLAN_SERVER_PLANNER_SERVICE_H_

#include <atomic>
#include <cstddef>
#include <memory>

#include "accel/risk_engine.h"
#include "grpcpp/grpcpp.h"
#include "riskplan/v1/planner.grpc.pb.h"
#include "server/feasibility_cache.h"
#include "server/map_registry.h"
#include "server/metrics.h"
#include "server/model_cache.h"
#include "server/open_calls.h"
#include "server/plan_call.h"
#include "server/request_validation.h"
#include "server/thread_pool.h"
#include "server/timer_queue.h"

namespace riskplan::server {

struct ServiceOptions {
  RequestLimits limits;
  int plan_threads = 2;            // planners running at once
  int max_running_plans = 4;       // admitted plans (planning or queued); more: RESOURCE_EXHAUSTED
  int eval_threads = 2;            // EvaluateRisk and GetMapLayer workers
  size_t max_queued_evals = 1024;  // waiting evaluations; more: RESOURCE_EXHAUSTED
  size_t max_cached_checkers = 8;  // two-tier feasibility checkers kept (EvaluateRisk.two_tier)
  // Computes every risk batch of plans and evaluations (CPU workers, FPGA
  // boards); null: each call computes its own on its thread. Not owned; must
  // outlive the service.
  accel::RiskEngine* engine = nullptr;
};

class PlannerService final : public v1::Planner::CallbackService {
 public:
  // `maps`, `models` and `metrics` must outlive the service.
  PlannerService(const MapRegistry& maps, RiskModelCache& models, ServerMetrics& metrics,
                 const ServiceOptions& options);
  // Waits for queued and running work. Call after the gRPC server has shut
  // down (no handler may run any more).
  ~PlannerService() override;

  grpc::ServerWriteReactor<v1::PlanUpdate>* PlanTrajectory(grpc::CallbackServerContext* ctx,
                                                           const v1::PlanRequest* request) override;
  grpc::ServerUnaryReactor* EvaluateRisk(grpc::CallbackServerContext* ctx,
                                         const v1::EvaluateRiskRequest* request,
                                         v1::EvaluateRiskResponse* response) override;
  grpc::ServerUnaryReactor* ListMaps(grpc::CallbackServerContext* ctx,
                                     const v1::ListMapsRequest* request,
                                     v1::ListMapsResponse* response) override;
  grpc::ServerUnaryReactor* GetMapLayer(grpc::CallbackServerContext* ctx,
                                        const v1::GetMapLayerRequest* request,
                                        v1::GetMapLayerResponse* response) override;
  grpc::ServerUnaryReactor* Ping(grpc::CallbackServerContext* ctx, const v1::PingRequest* request,
                                 v1::PingResponse* response) override;

  // From now on every new call gets UNAVAILABLE. Thread-safe.
  void StartDraining() { draining_.store(true); }
  bool draining() const { return draining_.load(); }

  ActivePlans& active_plans() { return active_; }
  // Calls of this service gRPC has not finished with (plans, evaluations...).
  const OpenCalls& open_calls() const { return open_calls_; }
  // The two-tier checkers of EvaluateRisk (for the cache metrics).
  std::shared_ptr<const FeasibilityCache> checkers() const { return checkers_; }

 private:
  const MapRegistry& maps_;
  RiskModelCache& models_;
  ServerMetrics& metrics_;
  const ServiceOptions options_;
  const std::shared_ptr<FeasibilityCache> checkers_;
  v1::ListMapsResponse map_list_;  // built once
  std::atomic<bool> draining_{false};
  ActivePlans active_;
  OpenCalls open_calls_;
  // Declared last: destroyed first, so queued tasks run while everything they
  // use is still alive.
  TimerQueue timer_;
  ThreadPool eval_pool_;
  ThreadPool plan_pool_;
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_PLANNER_SERVICE_H_
