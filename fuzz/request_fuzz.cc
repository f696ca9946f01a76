// Fuzz target: the server's handling of request bytes, from the raw gRPC
// message to the answer: ParseRequest (server/api/message_codec.h), the
// validation of an EvaluateRiskRequest or PlanRequest, and then what the
// service does with a request that passes, on a small demo-city (1 km at
// 10 m cells; "demo-city" without a geo-reference, and the same layers as
// "geo-city" with one, so that the WGS84 fields of requests and answers are
// converted too) under small limits, so that every limit can be reached: an
// evaluation (RunEvaluation, with the two-tier check) or a plan of a few tens
// of milliseconds with its improvements and final message converted as the
// stream would send them; every response is serialised.
//
// Input: one byte choosing the method (even: EvaluateRisk; 1 mod 4:
// PlanTrajectory; 3 mod 4: PlanFleet, validated and grouped into the
// missions planned together, not planned: its missions are PlanRequests,
// planned by the PlanTrajectory branch), then the request message's bytes
// (protobuf wire format).
//
// Properties: an error is a status the API documents for these calls
// (INVALID_ARGUMENT, NOT_FOUND, RESOURCE_EXHAUSTED) with a message, never
// INTERNAL or UNKNOWN; no exception escapes (the server would answer it with
// INTERNAL); a plan's improvements and final message always convert, and
// every number of an answer is finite. A fleet: its refusal is
// INVALID_ARGUMENT; a mission's own error is a documented status naming
// "missions[i]"; every valid mission is in exactly one group, a shared group
// holds 2 to kMaxSharedTreeMissions RISK_RRT_STAR missions with one map,
// goal and seed, and a group's priority is the highest of its missions'.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <exception>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/base/cancellation.h"
#include "core/planners/planner.h"
#include "core/planners/shared_goal_tree.h"
#include "fuzz/fuzz_server.h"
#include "fuzz/fuzz_support.h"
#include "google/protobuf/stubs/logging.h"
#include "grpcpp/grpcpp.h"
#include "riskplan/v1/planner.pb.h"
#include "server/models/feasibility_cache.h"
#include "server/fleet/fleet_request.h"
#include "server/models/map_registry.h"
#include "server/api/message_codec.h"
#include "server/models/model_cache.h"
#include "server/planner_service.h"
#include "server/api/proto_convert.h"
#include "server/api/request_validation.h"

namespace riskplan::fuzz {
namespace {

using namespace riskplan::server;

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
    maps = FuzzMaps();
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
  absl::StatusOr<PlanResult> result =
      (*planner)->Plan(problem, spec->options, cancel, [&](const PlanImprovement& improvement) {
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

void PlanFleet(Server& server, const grpc::ByteBuffer& raw) {
  v1::FleetRequest request;
  if (absl::Status s = ParseRequest(raw, &request); !s.ok()) {
    CheckError(s);
    return;
  }
  absl::StatusOr<FleetSpec> spec = ValidateFleetRequest(request, *server.maps, server.limits);
  if (!spec.ok()) {
    if (spec.status().code() != absl::StatusCode::kInvalidArgument) Fail(spec.status().ToString());
    CheckError(spec.status());
    return;
  }
  if (spec->missions.size() != static_cast<size_t>(request.missions_size())) {
    Fail("a fleet spec without one entry per mission");
  }
  std::vector<int> seen(spec->missions.size(), 0);
  for (size_t i = 0; i < spec->missions.size(); ++i) {
    const FleetMissionSpec& m = spec->missions[i];
    if (m.plan.ok()) continue;
    CheckError(m.plan.status());
    const absl::Status named = MissionError(i, m.plan.status());
    if (named.message().find(absl::StrCat("missions[", i, "]")) == absl::string_view::npos) {
      Fail("a mission's error that does not name the mission");
    }
  }
  for (const MissionGroup& group : GroupMissions(*spec)) {
    if (group.missions.empty()) Fail("an empty mission group");
    int priority = -1;
    for (size_t index : group.missions) {
      if (index >= spec->missions.size() || !spec->missions[index].plan.ok()) {
        Fail("a group with a mission that is not valid");
      }
      ++seen[index];
      priority = std::max(priority, spec->missions[index].priority);
    }
    if (priority != group.priority) Fail("a group's priority is not its missions' highest");
    if (!group.shared) {
      if (group.missions.size() != 1) Fail("a group planned alone with more than one mission");
      continue;
    }
    if (group.missions.size() < 2 || group.missions.size() > kMaxSharedTreeMissions) {
      Fail("a shared goal tree of fewer than 2 or too many missions");
    }
    const PlanSpec& first = *spec->missions[group.missions[0]].plan;
    for (size_t index : group.missions) {
      const PlanSpec& p = *spec->missions[index].plan;
      if (p.algorithm != PlannerAlgorithm::kRiskRrtStar || p.map != first.map ||
          p.options.seed != first.options.seed ||
          std::memcmp(&p.goal, &first.goal, sizeof(Pose)) != 0) {
        Fail("a shared goal tree of missions that differ in algorithm, map, seed or goal");
      }
    }
  }
  for (size_t i = 0; i < spec->missions.size(); ++i) {
    if (seen[i] != (spec->missions[i].plan.ok() ? 1 : 0)) {
      Fail("a valid mission in no group or in two, or an invalid one in a group");
    }
  }
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
    } else if (data[0] % 4 == 1) {
      PlanTrajectory(*server, raw);
    } else {
      PlanFleet(*server, raw);
    }
  } catch (const std::exception& e) {
    Fail(std::string("an exception escaped: ") + e.what());
  }
  return 0;
}
