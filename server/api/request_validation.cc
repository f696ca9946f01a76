#include "server/api/request_validation.h"

#include <cmath>
#include <map>
#include <string>

#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "core/flight/trajectory.h"
#include "google/protobuf/descriptor.h"
#include "google/protobuf/reflection.h"
#include "server/api/wgs84_fields.h"
#include "server/api/wind_fields.h"

namespace riskplan::server {
namespace {

using google::protobuf::FieldDescriptor;

// The start or goal of a plan, from whichever frame the request gives it in,
// checked inside the map. `name` is "start" or "goal".
absl::StatusOr<Pose> PlanEndpoint(const MapRegistry& registry, const RiskMap& map, bool has_local,
                                  const v1::Pose& local, bool has_wgs84, const v1::GeoPose& wgs84,
                                  const std::string& name) {
  const std::string wgs84_name = name + "_wgs84";
  if (has_local) {
    absl::StatusOr<Pose> pose = PoseFromProto(local, name);
    if (!pose.ok()) return pose.status();
    if (absl::Status s = CheckInsideMap(map, *pose, name); !s.ok()) return s;
    return pose;
  }
  if (!has_wgs84) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s is required (or %s on a geo-referenced map)", name, wgs84_name));
  }
  absl::StatusOr<std::shared_ptr<const geo::GeoFrame>> frame =
      FrameForField(registry, map, wgs84_name, name);
  if (!frame.ok()) return frame.status();
  absl::StatusOr<geo::GeoPose> given = GeoPoseFromProto(wgs84, wgs84_name);
  if (!given.ok()) return given.status();
  absl::StatusOr<std::vector<Pose>> pose = PosesFromWgs84(**frame, {*given}, wgs84_name, true);
  if (!pose.ok()) return pose.status();
  if (absl::Status s = CheckWgs84InsideMap(map, **frame, (*pose)[0], *given, wgs84_name); !s.ok()) {
    return s;
  }
  return (*pose)[0];
}

// The start and the goal, from whichever frame the request gives each in.
absl::Status PlanEndpoints(const v1::PlanRequest& request, const MapRegistry& registry,
                           PlanSpec* spec) {
  absl::StatusOr<Pose> start =
      PlanEndpoint(registry, *spec->map, request.has_start(), request.start(),
                   request.has_start_wgs84(), request.start_wgs84(), "start");
  if (!start.ok()) return start.status();
  absl::StatusOr<Pose> goal = PlanEndpoint(registry, *spec->map, request.has_goal(), request.goal(),
                                           request.has_goal_wgs84(), request.goal_wgs84(), "goal");
  if (!goal.ok()) return goal.status();
  spec->start = *start;
  spec->goal = *goal;
  return absl::OkStatus();
}

// The time and iteration budget, capped: every plan ends in bounded wall
// time, whatever its iteration budget.
absl::Status PlanBudget(const v1::PlanRequest& request, const RequestLimits& limits,
                        PlanOptions* options) {
  const int64_t time_ms = request.budget().time_ms();
  const int64_t iterations = request.budget().iterations();
  if (time_ms < 0 || time_ms > limits.max_plan_time_ms) {
    return absl::InvalidArgumentError(
        absl::StrFormat("budget.time_ms has value %d; it must be in [0, %d] (0: no time limit)",
                        time_ms, limits.max_plan_time_ms));
  }
  if (iterations < 0 || iterations > limits.max_iterations) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "budget.iterations has value %d; it must be in [0, %d] (0: no iteration limit)", iterations,
        limits.max_iterations));
  }
  int64_t effective_ms = time_ms;
  if (time_ms == 0)
    effective_ms = iterations == 0 ? limits.default_plan_time_ms : limits.max_plan_time_ms;
  options->budget.max_time_s = static_cast<double>(effective_ms) / 1000.0;
  options->budget.max_iterations = iterations;
  return absl::OkStatus();
}

// The model and planner parameters, and the work they ask for (the impact
// table's bytes, the samples of one edge), bounded before the plan is queued.
// Needs the start and goal (PlanEndpoints).
absl::Status PlanParams(const v1::PlanRequest& request, const MapRegistry& registry,
                        const RequestLimits& limits, PlanSpec* spec) {
  absl::StatusOr<ModelParams> params = ModelParamsFromProto(request.model_params());
  if (!params.ok()) return params.status();
  spec->params = *params;
  if (absl::Status s = ApplyRequestWind(RequestWindOf(request), registry, *spec->map, &spec->params);
      !s.ok()) {
    return s;
  }
  spec->wind = WindReportOf(spec->params, *spec->map, spec->frame.get());
  if (absl::Status s = CheckModelWork(spec->params, limits); !s.ok()) return s;

  if (absl::Status s = CheckPlannerParams(spec->algorithm, request.planner_params()); !s.ok()) {
    return s;
  }
  spec->options.params.insert(request.planner_params().begin(), request.planner_params().end());
  // The planner checks the same bound again (CheckEdgeSamples); here it
  // refuses the request before it is queued.
  spec->options.max_edge_samples = limits.max_edge_samples;
  if (absl::Status s =
          CheckEdgeSampleBound(spec->algorithm, *spec->map, spec->params, spec->start, spec->goal,
                               spec->options.params, limits.max_edge_samples, "--max_edge_samples");
      !s.ok()) {
    return InField("model_params", s);
  }
  return absl::OkStatus();
}

// How often the stream may send an update, and the step of its display path.
absl::Status PlanUpdates(const v1::PlanRequest& request, const RequestLimits& limits,
                         PlanSpec* spec) {
  const int64_t interval_ms = request.min_update_interval_ms();
  if (interval_ms < 0 || interval_ms > limits.max_update_interval_ms) {
    return absl::InvalidArgumentError(
        absl::StrFormat("min_update_interval_ms has value %d; it must be in [0, %d]", interval_ms,
                        limits.max_update_interval_ms));
  }
  spec->min_update_interval = absl::Milliseconds(interval_ms);

  const double step = request.display_step_m();
  if (step != 0.0 && !(std::isfinite(step) && step >= 1.0 && step <= 1000.0)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "display_step_m has value %g; it must be finite and in [1, 1000] (0: 25 m)", step));
  }
  spec->display_step_m = step == 0.0 ? 25.0 : step;
  return absl::OkStatus();
}

// The numbers of obstacle points and dynamic obstacle areas, checked before
// any is read, so that the loops after it (and the planners) only ever see a
// bounded number of points and areas.
absl::Status CheckObstacleCounts(const v1::PlanRequest& request, const RequestLimits& limits) {
  if (static_cast<size_t>(request.obstacle_points_size()) +
          static_cast<size_t>(request.obstacle_points_wgs84_size()) >
      limits.max_obstacle_points) {
    if (request.obstacle_points_wgs84_size() == 0) {
      return absl::InvalidArgumentError(
          absl::StrFormat("obstacle_points has %d points; the limit is %d",
                          request.obstacle_points_size(), limits.max_obstacle_points));
    }
    return absl::InvalidArgumentError(absl::StrFormat(
        "obstacle_points has %d points and obstacle_points_wgs84 %d; the limit is %d together",
        request.obstacle_points_size(), request.obstacle_points_wgs84_size(),
        limits.max_obstacle_points));
  }
  if (static_cast<size_t>(request.dynamic_obstacles_size()) > kMaxDynamicObstacles) {
    return absl::InvalidArgumentError(
        absl::StrFormat("dynamic_obstacles has %d areas; the limit is %d",
                        request.dynamic_obstacles_size(), kMaxDynamicObstacles));
  }
  return absl::OkStatus();
}

// obstacle_points_wgs84 into the map's local frame, appended to `points`.
absl::Status Wgs84ObstaclePoints(const v1::PlanRequest& request, const MapRegistry& registry,
                                 const RiskMap& map, std::vector<Point2>* points) {
  absl::StatusOr<std::shared_ptr<const geo::GeoFrame>> frame =
      FrameForField(registry, map, "obstacle_points_wgs84", "obstacle_points");
  if (!frame.ok()) return frame.status();
  std::vector<geo::LatLon> given;
  given.reserve(request.obstacle_points_wgs84_size());
  for (int i = 0; i < request.obstacle_points_wgs84_size(); ++i) {
    const v1::GeoPoint2& p = request.obstacle_points_wgs84(i);
    if (absl::Status s =
            CheckLatLon(p.lat_deg(), p.lon_deg(), absl::StrFormat("obstacle_points_wgs84[%d]", i));
        !s.ok()) {
      return s;
    }
    given.push_back({p.lat_deg(), p.lon_deg()});
  }
  absl::StatusOr<std::vector<geo::LocalXY>> local =
      PointsFromWgs84(**frame, given, "obstacle_points_wgs84");
  if (!local.ok()) return local.status();
  for (const geo::LocalXY& p : *local) points->push_back(Point2{p.x, p.y});
  return absl::OkStatus();
}

// dynamic_obstacles, each a finite, non-empty rectangle from an iteration
// >= 0, appended to `obstacles`.
absl::Status DynamicObstaclesFromProto(const v1::PlanRequest& request,
                                       std::vector<DynamicObstacle>* obstacles) {
  for (int i = 0; i < request.dynamic_obstacles_size(); ++i) {
    const v1::DynamicObstacle& o = request.dynamic_obstacles(i);
    const std::string field = absl::StrFormat("dynamic_obstacles[%d]", i);
    for (auto [name, value] : {std::pair{"x0_m", o.x0_m()},
                               {"y0_m", o.y0_m()},
                               {"x1_m", o.x1_m()},
                               {"y1_m", o.y1_m()}}) {
      if (absl::Status s = CheckFinite(value, field + "." + name); !s.ok()) return s;
    }
    if (o.at_iteration() < 0 || !(o.x0_m() < o.x1_m()) || !(o.y0_m() < o.y1_m())) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "%s is at_iteration %d, [%g, %g] x [%g, %g]; it needs at_iteration >= 0, x0_m < "
          "x1_m and y0_m < y1_m",
          field, o.at_iteration(), o.x0_m(), o.x1_m(), o.y0_m(), o.y1_m()));
    }
    obstacles->push_back(DynamicObstacle{o.at_iteration(), o.x0_m(), o.y0_m(), o.x1_m(), o.y1_m()});
  }
  return absl::OkStatus();
}

// The obstacle points (local, then WGS84) and the dynamic obstacles.
absl::Status PlanObstacles(const v1::PlanRequest& request, const MapRegistry& registry,
                           const RequestLimits& limits, PlanSpec* spec) {
  if (absl::Status s = CheckObstacleCounts(request, limits); !s.ok()) return s;
  for (int i = 0; i < request.obstacle_points_size(); ++i) {
    const v1::Point2& p = request.obstacle_points(i);
    const std::string field = absl::StrFormat("obstacle_points[%d]", i);
    if (absl::Status s = CheckFinite(p.x(), field + ".x"); !s.ok()) return s;
    if (absl::Status s = CheckFinite(p.y(), field + ".y"); !s.ok()) return s;
    spec->options.obstacle_points.push_back(Point2{p.x(), p.y()});
  }
  if (request.obstacle_points_wgs84_size() > 0) {
    if (absl::Status s =
            Wgs84ObstaclePoints(request, registry, *spec->map, &spec->options.obstacle_points);
        !s.ok()) {
      return s;
    }
  }
  if (absl::Status s = DynamicObstaclesFromProto(request, &spec->options.dynamic_obstacles);
      !s.ok()) {
    return s;
  }
  // A planner that cannot honour a reported hazard refuses it rather than
  // dropping it silently.
  return CheckRequestObstacles(spec->algorithm, spec->options);
}

// The number of points of an EvaluateRisk trajectory, `count` `noun`s in
// `field`: 2 to limits.max_waypoints.
absl::Status CheckPointCount(int count, const char* field, const char* noun,
                             const RequestLimits& limits) {
  if (count < 2 || static_cast<size_t>(count) > limits.max_waypoints) {
    return absl::InvalidArgumentError(absl::StrFormat("%s has %d %s; it must have 2 to %d", field,
                                                      count, noun, limits.max_waypoints));
  }
  return absl::OkStatus();
}

absl::Status LocalWaypoints(const v1::EvaluateRiskRequest& request, const RequestLimits& limits,
                            EvaluateSpec* spec) {
  const auto& poses = request.waypoints().poses();
  if (absl::Status s = CheckPointCount(poses.size(), "waypoints.poses", "poses", limits); !s.ok()) {
    return s;
  }
  spec->waypoints.reserve(poses.size());
  for (int i = 0; i < poses.size(); ++i) {
    absl::StatusOr<Pose> pose = PoseFromProto(poses[i], absl::StrFormat("waypoints.poses[%d]", i));
    if (!pose.ok()) return pose.status();
    spec->waypoints.push_back(*pose);
  }
  return absl::OkStatus();
}

absl::Status LocalPolyline(const v1::EvaluateRiskRequest& request, const RequestLimits& limits,
                           EvaluateSpec* spec) {
  const auto& points = request.polyline().points();
  if (absl::Status s = CheckPointCount(points.size(), "polyline.points", "points", limits);
      !s.ok()) {
    return s;
  }
  spec->polyline.reserve(points.size());
  for (int i = 0; i < points.size(); ++i) {
    const v1::Point3& p = points[i];
    const std::string field = absl::StrFormat("polyline.points[%d]", i);
    if (absl::Status s = CheckFinite(p.x(), field + ".x"); !s.ok()) return s;
    if (absl::Status s = CheckFinite(p.y(), field + ".y"); !s.ok()) return s;
    if (absl::Status s = CheckFinite(p.z(), field + ".z"); !s.ok()) return s;
    spec->polyline.push_back(Point3{p.x(), p.y(), p.z()});
  }
  return absl::OkStatus();
}

absl::Status Wgs84Waypoints(const v1::EvaluateRiskRequest& request, const MapRegistry& registry,
                            const RequestLimits& limits, EvaluateSpec* spec) {
  const auto& poses = request.waypoints_wgs84().poses();
  if (absl::Status s = CheckPointCount(poses.size(), "waypoints_wgs84.poses", "poses", limits);
      !s.ok()) {
    return s;
  }
  absl::StatusOr<std::shared_ptr<const geo::GeoFrame>> frame =
      FrameForField(registry, *spec->map, "waypoints_wgs84", "waypoints");
  if (!frame.ok()) return frame.status();
  std::vector<geo::GeoPose> given;
  given.reserve(poses.size());
  for (int i = 0; i < poses.size(); ++i) {
    absl::StatusOr<geo::GeoPose> pose =
        GeoPoseFromProto(poses[i], absl::StrFormat("waypoints_wgs84.poses[%d]", i));
    if (!pose.ok()) return pose.status();
    given.push_back(*pose);
  }
  absl::StatusOr<std::vector<Pose>> local =
      PosesFromWgs84(**frame, given, "waypoints_wgs84.poses", /*single=*/false);
  if (!local.ok()) return local.status();
  spec->waypoints = *std::move(local);
  return absl::OkStatus();
}

absl::Status Wgs84Polyline(const v1::EvaluateRiskRequest& request, const MapRegistry& registry,
                           const RequestLimits& limits, EvaluateSpec* spec) {
  const auto& points = request.polyline_wgs84().points();
  if (absl::Status s = CheckPointCount(points.size(), "polyline_wgs84.points", "points", limits);
      !s.ok()) {
    return s;
  }
  absl::StatusOr<std::shared_ptr<const geo::GeoFrame>> frame =
      FrameForField(registry, *spec->map, "polyline_wgs84", "polyline");
  if (!frame.ok()) return frame.status();
  std::vector<geo::LatLon> given;
  given.reserve(points.size());
  for (int i = 0; i < points.size(); ++i) {
    const v1::GeoPoint3& p = points[i];
    const std::string field = absl::StrFormat("polyline_wgs84.points[%d]", i);
    if (absl::Status s = CheckLatLon(p.lat_deg(), p.lon_deg(), field); !s.ok()) return s;
    if (absl::Status s = CheckFinite(p.alt_m(), field + ".alt_m"); !s.ok()) return s;
    given.push_back({p.lat_deg(), p.lon_deg()});
  }
  absl::StatusOr<std::vector<geo::LocalXY>> local =
      PointsFromWgs84(**frame, given, "polyline_wgs84.points");
  if (!local.ok()) return local.status();
  spec->polyline.reserve(points.size());
  for (int i = 0; i < points.size(); ++i) {
    spec->polyline.push_back(Point3{(*local)[i].x, (*local)[i].y, points[i].alt_m()});
  }
  return absl::OkStatus();
}

// The trajectory of an EvaluateRiskRequest, in whichever of its four forms
// it comes, into spec->waypoints or spec->polyline. Point counts are checked
// before any point is read or copied, so a huge request costs no more than
// its parsing (which --max_request_bytes bounds).
absl::Status TrajectoryFromProto(const v1::EvaluateRiskRequest& request,
                                 const MapRegistry& registry, const RequestLimits& limits,
                                 EvaluateSpec* spec) {
  switch (request.trajectory_case()) {
    case v1::EvaluateRiskRequest::kWaypoints:
      return LocalWaypoints(request, limits, spec);
    case v1::EvaluateRiskRequest::kPolyline:
      return LocalPolyline(request, limits, spec);
    case v1::EvaluateRiskRequest::kWaypointsWgs84:
      return Wgs84Waypoints(request, registry, limits, spec);
    case v1::EvaluateRiskRequest::kPolylineWgs84:
      return Wgs84Polyline(request, registry, limits, spec);
    default:
      return absl::InvalidArgumentError(
          "trajectory is required: set waypoints (poses) or polyline (points), or on a "
          "geo-referenced map waypoints_wgs84 or polyline_wgs84");
  }
}

}  // namespace

// By reflection: every field of ModelParameters is named after a ModelParam,
// so a parameter added to both needs no code here. Only fields the request
// sets (explicit presence) override the defaults.
absl::StatusOr<ModelParams> ModelParamsFromProto(const v1::ModelParameters& proto) {
  ModelParams params;
  const google::protobuf::Descriptor* descriptor = proto.GetDescriptor();
  const google::protobuf::Reflection* reflection = proto.GetReflection();
  for (int i = 0; i < descriptor->field_count(); ++i) {
    const FieldDescriptor* field = descriptor->field(i);
    if (!reflection->HasField(proto, field)) continue;
    double value = 0.0;
    switch (field->cpp_type()) {
      case FieldDescriptor::CPPTYPE_DOUBLE:
        value = reflection->GetDouble(proto, field);
        break;
      case FieldDescriptor::CPPTYPE_INT32:
        value = reflection->GetInt32(proto, field);
        break;
      default:
        return absl::InternalError(
            absl::StrFormat("model_params.%s has an unexpected type", field->name()));
    }
    if (absl::Status s = SetModelParam(&params, std::string_view(field->name()), value); !s.ok()) {
      return InField("model_params", s);
    }
  }
  if (absl::Status s = ValidateModelParams(params); !s.ok()) return InField("model_params", s);
  return params;
}

ModelBuildLimits BuildLimits(const RequestLimits& limits, StopCondition stop) {
  return ModelBuildLimits{.max_table_bytes = limits.max_table_bytes,
                          .max_table_bytes_source = "--max_table_bytes",
                          .stop = stop};
}

absl::Status CheckModelWork(const ModelParams& params, const RequestLimits& limits) {
  return InField("model_params", ImpactTable::CheckMinBytes(params, BuildLimits(limits)));
}

absl::StatusOr<Pose> PoseFromProto(const v1::Pose& pose, std::string_view field) {
  const std::string f(field);
  if (absl::Status s = CheckFinite(pose.x(), f + ".x"); !s.ok()) return s;
  if (absl::Status s = CheckFinite(pose.y(), f + ".y"); !s.ok()) return s;
  if (absl::Status s = CheckFinite(pose.z(), f + ".z"); !s.ok()) return s;
  if (absl::Status s = CheckFinite(pose.theta(), f + ".theta"); !s.ok()) return s;
  return Pose{pose.x(), pose.y(), pose.z(), NormalizeHeading(pose.theta())};
}

absl::StatusOr<std::shared_ptr<const RiskMap>> FindMap(const MapRegistry& registry,
                                                       std::string_view name) {
  if (name.empty()) {
    return absl::InvalidArgumentError(
        absl::StrFormat("map is required; served maps: %s", registry.NameList()));
  }
  std::shared_ptr<const RiskMap> map = registry.Find(name);
  if (map == nullptr) {
    return absl::NotFoundError(absl::StrFormat("map '%s' is not served; served maps: %s",
                                               std::string(name), registry.NameList()));
  }
  return map;
}

absl::Status CheckInsideMap(const RiskMap& map, const Pose& pose, std::string_view field) {
  // Only (x, y): altitude rules need the risk model and are the
  // admissibility check's (CheckEndpoints), later.
  int i = 0, j = 0;
  if (map.CellOf(pose.x, pose.y, &i, &j)) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrFormat(
      "%s (x, y) = (%g, %g) is outside map '%s', which covers x in [%g, %g), y in [%g, %g)",
      std::string(field), pose.x, pose.y, map.name(), map.x0(), map.x0() + map.width_m(), map.y0(),
      map.y0() + map.height_m()));
}

absl::StatusOr<PlannerAlgorithm> AlgorithmFromProto(int algorithm) {
  switch (algorithm) {
    case v1::ALGORITHM_UNSPECIFIED:
    case v1::RISK_RRT_STAR:
      return PlannerAlgorithm::kRiskRrtStar;
    case v1::RRT:
      return PlannerAlgorithm::kRrt;
    case v1::GENETIC:
      return PlannerAlgorithm::kGenetic;
    case v1::HARMONIC:
      return PlannerAlgorithm::kHarmonic;
    default:
      return absl::InvalidArgumentError(absl::StrFormat(
          "algorithm has value %d, which this server does not offer; known: RISK_RRT_STAR (1), "
          "RRT (2), GENETIC (3), HARMONIC (4)",
          algorithm));
  }
}

absl::Status CheckPlannerParams(PlannerAlgorithm algorithm,
                                const google::protobuf::Map<std::string, double>& params) {
  const std::vector<PlannerParamInfo>& infos = PlannerParams(algorithm);
  // Sorted, so that the first error is the same whatever the map's order.
  std::map<std::string, double> sorted(params.begin(), params.end());
  for (const auto& [name, value] : sorted) {
    const PlannerParamInfo* info = nullptr;
    for (const PlannerParamInfo& candidate : infos) {
      if (candidate.name == name) info = &candidate;
    }
    if (info == nullptr) {
      std::vector<std::string> known;
      for (const PlannerParamInfo& candidate : infos) known.push_back(candidate.name);
      return absl::InvalidArgumentError(absl::StrFormat(
          "planner_params: unknown parameter '%s' for %s; known: %s", name,
          std::string(PlannerAlgorithmName(algorithm)), absl::StrJoin(known, ", ")));
    }
    if (!std::isfinite(value) || value < info->min_value || value > info->max_value) {
      return absl::InvalidArgumentError(
          absl::StrFormat("planner_params['%s'] has value %g; it must be finite and in [%g, %g]",
                          name, value, info->min_value, info->max_value));
    }
  }
  return absl::OkStatus();
}

// PlanRequest.limits -> PlanOptions::limits (docs/api.md, "Limits").
static absl::Status PlanLimits(const v1::PlanRequest& request, PlanOptions* options) {
  const v1::FlightLimits& proto = request.limits();
  FlightLimits& limits = options->limits;
  limits.max_flight_time_s = proto.max_flight_time_s();
  limits.max_length_m = proto.max_length_m();
  limits.max_risk = proto.max_risk();
  limits.max_risk_per_flight_hour = proto.max_risk_per_flight_hour();
  limits.pareto = proto.pareto();
  switch (proto.objective()) {
    case v1::OBJECTIVE_UNSPECIFIED:
    case v1::MIN_RISK:
      limits.objective = PlanObjective::kMinRisk;
      break;
    case v1::MIN_TIME:
      limits.objective = PlanObjective::kMinTime;
      break;
    default:
      return absl::InvalidArgumentError(absl::StrFormat(
          "limits.objective has value %d; it must be MIN_RISK (1) or MIN_TIME (2) (0: MIN_RISK)",
          static_cast<int>(proto.objective())));
  }
  return CheckFlightLimits(limits);
}

absl::StatusOr<PlanSpec> ValidatePlanRequest(const v1::PlanRequest& request,
                                             const MapRegistry& registry,
                                             const RequestLimits& limits) {
  PlanSpec spec;
  absl::StatusOr<PlannerAlgorithm> algorithm = AlgorithmFromProto(request.algorithm());
  if (!algorithm.ok()) return algorithm.status();
  spec.algorithm = *algorithm;

  absl::StatusOr<std::shared_ptr<const RiskMap>> map = FindMap(registry, request.map());
  if (!map.ok()) return map.status();
  spec.map = *std::move(map);

  spec.frame = registry.Frame(spec.map->name());
  // The steps in this order, each field checked once: a client is told of
  // the first bad field in the request's order, whatever else is wrong.
  if (absl::Status s = PlanEndpoints(request, registry, &spec); !s.ok()) return s;
  if (absl::Status s = PlanBudget(request, limits, &spec.options); !s.ok()) return s;
  spec.options.seed = request.seed();
  spec.options.record_tree = request.include_tree();
  if (absl::Status s = PlanParams(request, registry, limits, &spec); !s.ok()) return s;
  if (absl::Status s = PlanUpdates(request, limits, &spec); !s.ok()) return s;
  if (absl::Status s = PlanObstacles(request, registry, limits, &spec); !s.ok()) return s;
  if (absl::Status s = PlanLimits(request, &spec.options); !s.ok()) return s;
  return spec;
}

absl::StatusOr<TwoTierOptions> TwoTierOptionsFromProto(const v1::TwoTierOptions& proto) {
  TwoTierOptions options;
  switch (proto.rule()) {
    case v1::COLLISION_RULE_UNSPECIFIED:
    case v1::FLIGHT_BAND:
      options.rule = CollisionRule::kFlightBand;
      break;
    case v1::TERRAIN_ONLY:
      options.rule = CollisionRule::kTerrain;
      break;
    default:
      return absl::InvalidArgumentError(
          absl::StrFormat("two_tier.rule has value %d; it must be FLIGHT_BAND (1) or "
                          "TERRAIN_ONLY (2) (0: FLIGHT_BAND)",
                          static_cast<int>(proto.rule())));
  }
  if (proto.has_detailed_segments()) options.detailed_segments = proto.detailed_segments();
  if (proto.has_block_cells()) options.block_cells = proto.block_cells();
  options.traversal = proto.bresenham() ? CellTraversal::kBresenham : CellTraversal::kSupercover;
  if (options.detailed_segments < 0) {
    return absl::InvalidArgumentError(
        absl::StrFormat("two_tier.detailed_segments has value %d; it must be >= 0 (unset: 2)",
                        options.detailed_segments));
  }
  // The checker's own limits, e.g. "two_tier: two-tier feasibility:
  // block_cells is 0; it must be in [1, 1024]".
  if (absl::Status s = CheckTwoTierOptions(options); !s.ok()) return InField("two_tier", s);
  return options;
}

absl::StatusOr<EvaluateSpec> ValidateEvaluateRequest(const v1::EvaluateRiskRequest& request,
                                                     const MapRegistry& registry,
                                                     const RequestLimits& limits) {
  EvaluateSpec spec;
  absl::StatusOr<std::shared_ptr<const RiskMap>> map = FindMap(registry, request.map());
  if (!map.ok()) return map.status();
  spec.map = *std::move(map);

  if (absl::Status s = TrajectoryFromProto(request, registry, limits, &spec); !s.ok()) return s;
  spec.frame = registry.Frame(spec.map->name());

  absl::StatusOr<ModelParams> params = ModelParamsFromProto(request.model_params());
  if (!params.ok()) return params.status();
  spec.params = *params;
  if (absl::Status s = ApplyRequestWind(RequestWindOf(request), registry, *spec.map, &spec.params);
      !s.ok()) {
    return s;
  }
  spec.wind = WindReportOf(spec.params, *spec.map, spec.frame.get());
  if (absl::Status s = CheckModelWork(spec.params, limits); !s.ok()) return s;
  spec.include_samples = request.include_samples();
  // Checked even when disabled, so that a client learns of a bad option
  // before it turns the check on.
  absl::StatusOr<TwoTierOptions> two_tier = TwoTierOptionsFromProto(request.two_tier());
  if (!two_tier.ok()) return two_tier.status();
  if (request.two_tier().enabled()) spec.two_tier = *two_tier;
  const double spacing = request.path_spacing_m();
  if (spacing != 0.0 && !(std::isfinite(spacing) && spacing >= 1.0 && spacing <= 100000.0)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "path_spacing_m has value %g; it must be finite and in [1, 100000] (0: no path)", spacing));
  }
  spec.path_spacing_m = spacing;
  return spec;
}

absl::Status CheckPathCount(double length_m, double spacing_m, const RequestLimits& limits) {
  const int64_t poses = PathPoseCount(length_m, spacing_m);
  if (poses > limits.max_response_samples) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "path_spacing_m: the path of %.1f m sampled every %g m has %d poses; at most %d can be "
        "returned (--max_response_samples)",
        length_m, spacing_m, poses, limits.max_response_samples));
  }
  return absl::OkStatus();
}

absl::Status CheckSampleCount(int64_t samples, double length_m, double sample_step_m,
                              bool include_samples, const RequestLimits& limits) {
  if (samples > limits.max_eval_samples) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "trajectory has %d samples (length %.1f m at sample_step_m %g); the limit is %d", samples,
        length_m, sample_step_m, limits.max_eval_samples));
  }
  if (include_samples && samples > limits.max_response_samples) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "include_samples: trajectory has %d samples (length %.1f m at sample_step_m %g); at "
        "most %d can be returned",
        samples, length_m, sample_step_m, limits.max_response_samples));
  }
  return absl::OkStatus();
}

}  // namespace riskplan::server
