// Fuzz target: the server's handling of request bytes, from the raw gRPC
// message to the answer: ParseRequest (server/message_codec.h), the
// validation of an EvaluateRiskRequest or PlanRequest, and then what the
// service does with a request that passes, on a small demo-city (1 km at
// 10 m cells; "demo-city" without a geo-reference, and the same layers as
// "geo-city" with one, so that the WGS84 fields of requests and answers are
// converted too) under small limits, so that every limit can be reached: an
// evaluation (RunEvaluation, with the two-tier check) or a plan of a few tens
// of milliseconds with its improvements and final message converted as the
// stream would send them; every response is serialised.
//
// Input: one byte choosing the method (even: EvaluateRisk, odd:
// PlanTrajectory), then the request message's bytes (protobuf wire format).
//
// Properties: an error is a status the API documents for these calls
// (INVALID_ARGUMENT, NOT_FOUND, RESOURCE_EXHAUSTED) with a message, never
// INTERNAL or UNKNOWN; no exception escapes (the server would answer it with
// INTERNAL); a plan's improvements and final message always convert, and
// every number of an answer is finite.
#include <cmath>
#include <cstdint>
#include <exception>
#include <memory>
#include <string>

#include "absl/status/status.h"
#include "core/base/cancellation.h"
#include "core/map/demo_city.h"
#include "core/map/risk_map.h"
#include "core/planners/planner.h"
#include "fuzz/fuzz_support.h"
#include "google/protobuf/stubs/logging.h"
#include "grpcpp/grpcpp.h"
#include "riskplan/v1/planner.pb.h"
#include "server/feasibility_cache.h"
#include "server/map_registry.h"
#include "server/message_codec.h"
#include "server/model_cache.h"
#include "server/planner_service.h"
#include "server/proto_convert.h"
#include "server/request_validation.h"

namespace riskplan::fuzz {
namespace {

using namespace riskplan::server;

RequestLimits FuzzLimits() {
  RequestLimits limits;
  limits.max_plan_time_ms = 40;
  limits.default_plan_time_ms = 10;
  limits.max_iterations = 100000;
  limits.max_update_interval_ms = 1000;
  limits.max_waypoints = 64;
  limits.max_eval_samples = 4000;
  limits.max_response_samples = 500;
  limits.max_obstacle_points = 64;
  limits.max_edge_samples = 20000;
  limits.max_table_bytes = size_t{32} << 20;
  return limits;
}

// What every input shares: the map, the model cache (the default model built
// once), the limits.
struct Server {
  RequestLimits limits = FuzzLimits();
  std::unique_ptr<MapRegistry> maps;
  std::unique_ptr<RiskModelCache> models;
  std::unique_ptr<FeasibilityCache> checkers = std::make_unique<FeasibilityCache>(2);

  Server() {
    // Protobuf's messages while parsing (a string field that is not UTF-8)
    // would flood the fuzzer's output; riskplan-server routes them into its
    // log (RouteProtobufLogs, tested in tests/server/rpc_log_test.cc).
    google::protobuf::SetLogHandler(nullptr);
    absl::StatusOr<std::shared_ptr<const RiskMap>> city =
        MakeDemoCity(DemoCityOptions{.size_m = 1000.0, .res_m = 10.0});
    if (!city.ok()) Fail(city.status().ToString());
    MapHeader header = (*city)->header();
    header.name = "geo-city";
    header.geo = GeoReference{49.6, 6.1, "azimuthal equidistant on WGS84 at the origin"};
    absl::StatusOr<std::shared_ptr<const RiskMap>> geo_city =
        RiskMap::Create(std::move(header), (*city)->layers());
    if (!geo_city.ok()) Fail(geo_city.status().ToString());
    absl::StatusOr<std::unique_ptr<MapRegistry>> registry =
        MapRegistry::FromMaps({*city, *geo_city});
    if (!registry.ok()) Fail(registry.status().ToString());
    maps = *std::move(registry);
    absl::StatusOr<std::unique_ptr<RiskModelCache>> cache =
        RiskModelCache::Create(*maps, /*max_overridden=*/4, BuildLimits(limits));
    if (!cache.ok()) Fail(cache.status().ToString());
    models = *std::move(cache);
  }
};

void CheckError(const absl::Status& status) {
  if (status.ok()) return;
  if (status.message().empty()) Fail("an error without a message");
  switch (status.code()) {
    case absl::StatusCode::kInvalidArgument:
    case absl::StatusCode::kNotFound:
    case absl::StatusCode::kResourceExhausted:
      return;
    default:
      Fail(status.ToString());
  }
}

template <typename Message>
void CheckSerialises(const Message& message) {
  grpc::ByteBuffer raw;
  if (absl::Status s = SerializeMessage(message, &raw); !s.ok()) Fail(s.ToString());
}

void CheckTrajectory(const v1::Trajectory& t) {
  if (!std::isfinite(t.risk()) || !std::isfinite(t.length_m())) Fail("a non-finite trajectory");
  for (const v1::Pose& p : t.waypoints()) {
    if (!std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.z()) ||
        !std::isfinite(p.theta())) {
      Fail("a non-finite waypoint");
    }
  }
}

void Evaluate(Server& server, const grpc::ByteBuffer& raw) {
  v1::EvaluateRiskRequest request;
  if (absl::Status s = ParseRequest(raw, &request); !s.ok()) {
    CheckError(s);
    return;
  }
  absl::StatusOr<EvaluateSpec> spec = ValidateEvaluateRequest(request, *server.maps, server.limits);
  if (!spec.ok()) {
    CheckError(spec.status());
    return;
  }
  v1::EvaluateRiskResponse response;
  const absl::Status s = RunEvaluation(*server.models, *server.checkers, /*engine=*/nullptr,
                                       server.limits, *spec, StopCondition(), &response);
  CheckError(s);
  if (!s.ok()) return;
  if (!std::isfinite(response.risk()) || !std::isfinite(response.length_m())) {
    Fail("a non-finite evaluation");
  }
  CheckSerialises(response);
}

void PlanTrajectory(Server& server, const grpc::ByteBuffer& raw) {
  v1::PlanRequest request;
  if (absl::Status s = ParseRequest(raw, &request); !s.ok()) {
    CheckError(s);
    return;
  }
  absl::StatusOr<PlanSpec> spec = ValidatePlanRequest(request, *server.maps, server.limits);
  if (!spec.ok()) {
    CheckError(spec.status());
    return;
  }
  // What PlanCall::Plan does on the plan pool.
  absl::StatusOr<std::shared_ptr<const RiskModel>> model =
      server.models->Get(*spec->map, spec->params);
  if (!model.ok()) {
    CheckError(InField("model_params", model.status()));
    return;
  }
  const PlanningProblem problem{*model, spec->start, spec->goal};
  if (absl::Status s = CheckEndpoints(problem); !s.ok()) {
    CheckError(s);
    return;
  }
  absl::StatusOr<std::unique_ptr<Planner>> planner = MakePlanner(spec->algorithm);
  if (!planner.ok()) Fail(planner.status().ToString());
  CancellationToken cancel;
  absl::StatusOr<PlanResult> result = (*planner)->Plan(
      problem, spec->options, cancel, [&](const PlanImprovement& improvement) {
        absl::StatusOr<v1::PlanUpdate> update =
            ImprovementToProto(improvement, spec->params, spec->display_step_m, spec->frame.get());
        if (!update.ok()) Fail(update.status().ToString());
        CheckTrajectory(update->trajectory());
        CheckSerialises(*update);
      });
  if (!result.ok()) {
    CheckError(result.status());
    return;
  }
  absl::StatusOr<v1::PlanUpdate> final_update =
      FinalUpdateToProto(*result, EndReasonToProto(result->reason, false), spec->params,
                         spec->display_step_m, spec->options.record_tree, spec->frame.get());
  if (!final_update.ok()) Fail(final_update.status().ToString());
  if (final_update->has_trajectory()) CheckTrajectory(final_update->trajectory());
  CheckSerialises(*final_update);
}

}  // namespace
}  // namespace riskplan::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace riskplan::fuzz;
  static Server* const server = new Server();  // lives for the whole run
  if (size == 0) return 0;
  grpc::Slice slice(data + 1, size - 1);
  const grpc::ByteBuffer raw(&slice, 1);
  try {
    if (data[0] % 2 == 0) {
      Evaluate(*server, raw);
    } else {
      PlanTrajectory(*server, raw);
    }
  } catch (const std::exception& e) {
    Fail(std::string("an exception escaped: ") + e.what());
  }
  return 0;
}
