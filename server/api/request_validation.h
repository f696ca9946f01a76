// Validation at the RPC edge: API messages in, checked domain values out.
//
// Every error is an absl::Status whose message names the offending field (as
// a path into the request, e.g. "start.z" or "model_params.mass_kg") and its
// value, so a client can fix the request without reading server logs. Codes:
//   INVALID_ARGUMENT  a value is missing, not finite, out of range, or unknown
//                     (algorithm, parameter name), or a pose lies outside the
//                     map, or there are too many points;
//   NOT_FOUND         the map name is not one the server serves.
// Admissibility of the start and goal needs a risk model and is checked later
// (CheckEndpoints, also INVALID_ARGUMENT).
#ifndef RISKPLAN_SERVER_API_REQUEST_VALIDATION_H_
#define RISKPLAN_SERVER_API_REQUEST_VALIDATION_H_

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "core/base/geometry.h"
#include "core/base/model_params.h"
#include "core/map/risk_map.h"
#include "core/planners/planner.h"
#include "core/planners/two_tier_feasibility.h"
#include "core/risk/impact_table.h"
#include "geo/geo_frame.h"
#include "riskplan/v1/planner.pb.h"
#include "server/api/field_checks.h"  // CheckFinite, InField: part of this header's API
#include "server/models/map_registry.h"

namespace riskplan::server {

// Limits the server enforces on requests (set from its flags).
struct RequestLimits {
  int64_t max_plan_time_ms = 600000;    // largest PlanRequest.budget.time_ms; also the cap
  int64_t default_plan_time_ms = 1000;  // when the budget sets neither limit
  int64_t max_iterations = 1000000000;
  int64_t max_update_interval_ms = 60000;
  size_t max_waypoints = 10000;           // EvaluateRisk points
  int64_t max_eval_samples = 2000000;     // midpoint samples of one EvaluateRisk
  int64_t max_response_samples = 200000;  // samples returned with include_samples
  size_t max_obstacle_points = 10000;     // PlanRequest.obstacle_points (<= kMaxObstaclePoints)
  int64_t max_edge_samples = kDefaultMaxEdgeSamples;  // samples of one edge of a plan
  size_t max_table_bytes = kDefaultMaxTableBytes;     // impact table of a request's parameters
  // Configuration risks of one GetRiskLayer (cells, times the heading bins
  // for the maximum over headings).
  int64_t max_risk_layer_evaluations = int64_t{1} << 24;
  size_t max_fleet_missions = 256;  // missions of one PlanFleet request
};

// The bounds of building a model for a request: --max_table_bytes, and
// `stop` (the server's drain).
ModelBuildLimits BuildLimits(const RequestLimits& limits, StopCondition stop = {});

// Converts the overrides onto the defaults and validates the result
// (ValidateModelParams); errors name "model_params.<field>".
absl::StatusOr<ModelParams> ModelParamsFromProto(const v1::ModelParameters& proto);

// The work a request's model parameters ask for, bounded before anything is
// queued: an impact table that cannot fit in limits.max_table_bytes whatever
// its kernels is INVALID_ARGUMENT naming the parameters, the bytes and the
// limit. (The exact size is checked when the table is built, off the gRPC
// thread.)
absl::Status CheckModelWork(const ModelParams& params, const RequestLimits& limits);

// Checks that the four numbers are finite; `field` names the pose in errors.
absl::StatusOr<Pose> PoseFromProto(const v1::Pose& pose, std::string_view field);

// Looks `name` up: INVALID_ARGUMENT when empty, NOT_FOUND when not served;
// both messages list the served maps.
absl::StatusOr<std::shared_ptr<const RiskMap>> FindMap(const MapRegistry& registry,
                                                       std::string_view name);

// INVALID_ARGUMENT when (x, y) of `pose` lies outside `map`.
absl::Status CheckInsideMap(const RiskMap& map, const Pose& pose, std::string_view field);

// A validated PlanRequest.
struct PlanSpec {
  std::shared_ptr<const RiskMap> map;
  // The map's WGS84 frame (null without a geo-reference): responses carry
  // both frames when it is set.
  std::shared_ptr<const geo::GeoFrame> frame;
  ModelParams params;
  PlannerAlgorithm algorithm = PlannerAlgorithm::kRiskRrtStar;
  Pose start;
  Pose goal;
  PlanOptions options;  // budget (capped), seed, planner params, record_tree, obstacles
  absl::Duration min_update_interval;
  double display_step_m = 25.0;
  // The wind of params, as every PlanUpdate echoes it.
  v1::WindReport wind;
};

absl::StatusOr<PlanSpec> ValidatePlanRequest(const v1::PlanRequest& request,
                                             const MapRegistry& registry,
                                             const RequestLimits& limits);

// Checks planner parameters by name against PlannerParams(algorithm): known
// name, finite, inside [min, max]. Errors name "planner_params['name']".
absl::Status CheckPlannerParams(PlannerAlgorithm algorithm,
                                const google::protobuf::Map<std::string, double>& params);

// A validated EvaluateRiskRequest; exactly one of waypoints and polyline is
// non-empty.
struct EvaluateSpec {
  std::shared_ptr<const RiskMap> map;
  std::shared_ptr<const geo::GeoFrame> frame;  // null without a geo-reference
  ModelParams params;
  std::vector<Pose> waypoints;
  std::vector<Point3> polyline;
  bool include_samples = false;
  // Set when two_tier.enabled; passed CheckTwoTierOptions().
  std::optional<TwoTierOptions> two_tier;
  // Spacing of EvaluateRiskResponse.path, m, in [1, 100000]; 0: no path.
  double path_spacing_m = 0.0;
  // The wind of params, as EvaluateRiskResponse echoes it.
  v1::WindReport wind;
};

// The options of EvaluateRiskRequest.two_tier (unset fields take their
// defaults), checked whether or not the check is enabled. Errors name
// "two_tier.<field>".
absl::StatusOr<TwoTierOptions> TwoTierOptionsFromProto(const v1::TwoTierOptions& proto);

absl::StatusOr<EvaluateSpec> ValidateEvaluateRequest(const v1::EvaluateRiskRequest& request,
                                                     const MapRegistry& registry,
                                                     const RequestLimits& limits);

// Checks the number of midpoint samples of a trajectory (the sum of its
// pieces' PartCount) against the limits, so that the evaluation and the
// response stay bounded however long the trajectory. `length_m` and
// `sample_step_m` only explain the count in the message.
absl::Status CheckSampleCount(int64_t samples, double length_m, double sample_step_m,
                              bool include_samples, const RequestLimits& limits);

// The number of poses of EvaluateRiskResponse.path for a trajectory of
// `length_m` at `spacing_m` (PathPoseCount), checked against
// --max_response_samples before the path is sampled.
absl::Status CheckPathCount(double length_m, double spacing_m, const RequestLimits& limits);

// The algorithm of a request: ALGORITHM_UNSPECIFIED and RISK_RRT_STAR give
// kRiskRrtStar, RRT, GENETIC and HARMONIC their planners; anything else is
// INVALID_ARGUMENT.
absl::StatusOr<PlannerAlgorithm> AlgorithmFromProto(int algorithm);

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_API_REQUEST_VALIDATION_H_
