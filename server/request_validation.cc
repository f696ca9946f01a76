#include "server/request_validation.h"

#include <cmath>
#include <map>
#include <string>
#include <tuple>

#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "core/flight/trajectory.h"
#include "google/protobuf/descriptor.h"
#include "google/protobuf/reflection.h"

namespace riskplan::server {
namespace {

using google::protobuf::FieldDescriptor;

absl::Status CheckFinite(double value, std::string_view field) {
  if (std::isfinite(value)) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrFormat("%s has value %g; it must be finite", std::string(field), value));
}

// A latitude and a longitude, each finite and in range, named by `field`.
absl::Status CheckLatLon(double lat, double lon, const std::string& field) {
  if (!(lat >= -90.0 && lat <= 90.0)) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s.lat_deg has value %g; it must be in [-90, 90]", field, lat));
  }
  if (!(lon >= -180.0 && lon <= 180.0)) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s.lon_deg has value %g; it must be in [-180, 180]", field, lon));
  }
  return absl::OkStatus();
}

// GeoFrame's batch errors start "pose K: " or "point K: "; for a single pose
// the field alone names it.
absl::Status ConversionError(const absl::Status& status, std::string_view field, bool single) {
  std::string message(status.message());
  if (single) {
    for (const std::string prefix : {"pose 0: ", "point 0: "}) {
      if (message.rfind(prefix, 0) == 0) message = message.substr(prefix.size());
    }
  }
  return absl::Status(status.code(), absl::StrFormat("%s: %s", std::string(field), message));
}

// WGS84 points (polyline points, obstacles) into the local frame; errors as
// PosesFromWgs84's.
absl::StatusOr<std::vector<geo::LocalXY>> PointsFromWgs84(const geo::GeoFrame& frame,
                                                          const std::vector<geo::LatLon>& points,
                                                          std::string_view field) {
  absl::StatusOr<std::vector<geo::LocalXY>> local = frame.ToLocal(points);
  if (!local.ok()) return ConversionError(local.status(), field, /*single=*/false);
  return local;
}

// INVALID_ARGUMENT when a pose given in WGS84 lies outside `map`: the message
// gives both frames, and the map's WGS84 box.
absl::Status CheckWgs84InsideMap(const RiskMap& map, const geo::GeoFrame& frame, const Pose& pose,
                                 const geo::GeoPose& given, std::string_view field) {
  int i = 0, j = 0;
  if (map.CellOf(pose.x, pose.y, &i, &j)) return absl::OkStatus();
  std::string box;
  absl::StatusOr<geo::GeoBounds> b =
      frame.BoundsOf(map.x0(), map.y0(), map.x0() + map.width_m(), map.y0() + map.height_m());
  if (b.ok()) {
    box = absl::StrFormat(" (latitudes %.6f to %.6f, longitudes %.6f to %.6f)", b->min_lat_deg,
                          b->max_lat_deg, b->min_lon_deg, b->max_lon_deg);
  }
  return absl::InvalidArgumentError(absl::StrFormat(
      "%s (lat, lon) = (%.9g, %.9g) deg, local (x, y) = (%.2f, %.2f) m, is outside map '%s', "
      "which covers x in [%g, %g), y in [%g, %g)%s",
      std::string(field), given.lat_deg, given.lon_deg, pose.x, pose.y, map.name(), map.x0(),
      map.x0() + map.width_m(), map.y0(), map.y0() + map.height_m(), box));
}

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

}  // namespace

absl::Status InField(std::string_view field, const absl::Status& status) {
  if (status.ok()) return status;
  return absl::Status(status.code(),
                      absl::StrFormat("%s: %s", std::string(field), status.message()));
}

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

absl::StatusOr<std::shared_ptr<const geo::GeoFrame>> FrameForField(const MapRegistry& registry,
                                                                   const RiskMap& map,
                                                                   std::string_view field,
                                                                   std::string_view local_field) {
  std::shared_ptr<const geo::GeoFrame> frame = registry.Frame(map.name());
  if (frame != nullptr) return frame;
  return absl::InvalidArgumentError(absl::StrFormat(
      "%s: map '%s' has no geo-reference, so it takes positions in its local metres only (%s)",
      std::string(field), map.name(), std::string(local_field)));
}

absl::StatusOr<geo::GeoPose> GeoPoseFromProto(const v1::GeoPose& pose, std::string_view field) {
  const std::string f(field);
  if (absl::Status s = CheckLatLon(pose.lat_deg(), pose.lon_deg(), f); !s.ok()) return s;
  if (absl::Status s = CheckFinite(pose.alt_m(), f + ".alt_m"); !s.ok()) return s;
  if (absl::Status s = CheckFinite(pose.heading_deg(), f + ".heading_deg"); !s.ok()) return s;
  return geo::GeoPose{pose.lat_deg(), pose.lon_deg(), pose.alt_m(), pose.heading_deg()};
}

absl::StatusOr<std::vector<Pose>> PosesFromWgs84(const geo::GeoFrame& frame,
                                                 const std::vector<geo::GeoPose>& poses,
                                                 std::string_view field, bool single) {
  absl::StatusOr<std::vector<Pose>> local = frame.ToLocal(poses);
  if (!local.ok()) return ConversionError(local.status(), field, single);
  return local;
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
  absl::StatusOr<Pose> start =
      PlanEndpoint(registry, *spec.map, request.has_start(), request.start(),
                   request.has_start_wgs84(), request.start_wgs84(), "start");
  if (!start.ok()) return start.status();
  absl::StatusOr<Pose> goal = PlanEndpoint(registry, *spec.map, request.has_goal(), request.goal(),
                                           request.has_goal_wgs84(), request.goal_wgs84(), "goal");
  if (!goal.ok()) return goal.status();
  spec.start = *start;
  spec.goal = *goal;

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
  // Every plan ends in bounded wall time, whatever its iteration budget.
  int64_t effective_ms = time_ms;
  if (time_ms == 0)
    effective_ms = iterations == 0 ? limits.default_plan_time_ms : limits.max_plan_time_ms;
  spec.options.budget.max_time_s = static_cast<double>(effective_ms) / 1000.0;
  spec.options.budget.max_iterations = iterations;
  spec.options.seed = request.seed();
  spec.options.record_tree = request.include_tree();

  absl::StatusOr<ModelParams> params = ModelParamsFromProto(request.model_params());
  if (!params.ok()) return params.status();
  spec.params = *params;
  if (absl::Status s = CheckModelWork(spec.params, limits); !s.ok()) return s;

  if (absl::Status s = CheckPlannerParams(spec.algorithm, request.planner_params()); !s.ok()) {
    return s;
  }
  spec.options.params.insert(request.planner_params().begin(), request.planner_params().end());
  // The planner checks the same bound again (CheckEdgeSamples); here it
  // refuses the request before it is queued.
  spec.options.max_edge_samples = limits.max_edge_samples;
  if (absl::Status s =
          CheckEdgeSampleBound(spec.algorithm, *spec.map, spec.params, spec.start, spec.goal,
                               spec.options.params, limits.max_edge_samples, "--max_edge_samples");
      !s.ok()) {
    return InField("model_params", s);
  }

  const int64_t interval_ms = request.min_update_interval_ms();
  if (interval_ms < 0 || interval_ms > limits.max_update_interval_ms) {
    return absl::InvalidArgumentError(
        absl::StrFormat("min_update_interval_ms has value %d; it must be in [0, %d]", interval_ms,
                        limits.max_update_interval_ms));
  }
  spec.min_update_interval = absl::Milliseconds(interval_ms);

  const double step = request.display_step_m();
  if (step != 0.0 && !(std::isfinite(step) && step >= 1.0 && step <= 1000.0)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "display_step_m has value %g; it must be finite and in [1, 1000] (0: 25 m)", step));
  }
  spec.display_step_m = step == 0.0 ? 25.0 : step;

  // Counts first, so that the loops below (and the planners) only ever see
  // a bounded number of points and areas.
  if (static_cast<size_t>(request.obstacle_points_size()) +
          static_cast<size_t>(request.obstacle_points_wgs84_size()) >
      limits.max_obstacle_points) {
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
  for (int i = 0; i < request.obstacle_points_size(); ++i) {
    const v1::Point2& p = request.obstacle_points(i);
    const std::string field = absl::StrFormat("obstacle_points[%d]", i);
    if (absl::Status s = CheckFinite(p.x(), field + ".x"); !s.ok()) return s;
    if (absl::Status s = CheckFinite(p.y(), field + ".y"); !s.ok()) return s;
    spec.options.obstacle_points.push_back(Point2{p.x(), p.y()});
  }
  if (request.obstacle_points_wgs84_size() > 0) {
    absl::StatusOr<std::shared_ptr<const geo::GeoFrame>> frame =
        FrameForField(registry, *spec.map, "obstacle_points_wgs84", "obstacle_points");
    if (!frame.ok()) return frame.status();
    std::vector<geo::LatLon> points;
    points.reserve(request.obstacle_points_wgs84_size());
    for (int i = 0; i < request.obstacle_points_wgs84_size(); ++i) {
      const v1::GeoPoint2& p = request.obstacle_points_wgs84(i);
      if (absl::Status s = CheckLatLon(p.lat_deg(), p.lon_deg(),
                                       absl::StrFormat("obstacle_points_wgs84[%d]", i));
          !s.ok()) {
        return s;
      }
      points.push_back({p.lat_deg(), p.lon_deg()});
    }
    absl::StatusOr<std::vector<geo::LocalXY>> local =
        PointsFromWgs84(**frame, points, "obstacle_points_wgs84");
    if (!local.ok()) return local.status();
    for (const geo::LocalXY& p : *local) spec.options.obstacle_points.push_back(Point2{p.x, p.y});
  }
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
    spec.options.dynamic_obstacles.push_back(
        DynamicObstacle{o.at_iteration(), o.x0_m(), o.y0_m(), o.x1_m(), o.y1_m()});
  }
  // A planner that cannot honour a reported hazard refuses it rather than
  // dropping it silently.
  if (absl::Status s = CheckRequestObstacles(spec.algorithm, spec.options); !s.ok()) return s;
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

  // Point counts are checked before any point is read or copied, so a huge
  // request costs no more than its parsing (which --max_request_bytes bounds).
  switch (request.trajectory_case()) {
    case v1::EvaluateRiskRequest::kWaypoints: {
      const auto& poses = request.waypoints().poses();
      if (poses.size() < 2 || static_cast<size_t>(poses.size()) > limits.max_waypoints) {
        return absl::InvalidArgumentError(
            absl::StrFormat("waypoints.poses has %d poses; it must have 2 to %d", poses.size(),
                            limits.max_waypoints));
      }
      spec.waypoints.reserve(poses.size());
      for (int i = 0; i < poses.size(); ++i) {
        absl::StatusOr<Pose> pose =
            PoseFromProto(poses[i], absl::StrFormat("waypoints.poses[%d]", i));
        if (!pose.ok()) return pose.status();
        spec.waypoints.push_back(*pose);
      }
      break;
    }
    case v1::EvaluateRiskRequest::kPolyline: {
      const auto& points = request.polyline().points();
      if (points.size() < 2 || static_cast<size_t>(points.size()) > limits.max_waypoints) {
        return absl::InvalidArgumentError(
            absl::StrFormat("polyline.points has %d points; it must have 2 to %d", points.size(),
                            limits.max_waypoints));
      }
      spec.polyline.reserve(points.size());
      for (int i = 0; i < points.size(); ++i) {
        const v1::Point3& p = points[i];
        const std::string field = absl::StrFormat("polyline.points[%d]", i);
        if (absl::Status s = CheckFinite(p.x(), field + ".x"); !s.ok()) return s;
        if (absl::Status s = CheckFinite(p.y(), field + ".y"); !s.ok()) return s;
        if (absl::Status s = CheckFinite(p.z(), field + ".z"); !s.ok()) return s;
        spec.polyline.push_back(Point3{p.x(), p.y(), p.z()});
      }
      break;
    }
    case v1::EvaluateRiskRequest::kWaypointsWgs84: {
      const auto& poses = request.waypoints_wgs84().poses();
      if (poses.size() < 2 || static_cast<size_t>(poses.size()) > limits.max_waypoints) {
        return absl::InvalidArgumentError(
            absl::StrFormat("waypoints_wgs84.poses has %d poses; it must have 2 to %d",
                            poses.size(), limits.max_waypoints));
      }
      absl::StatusOr<std::shared_ptr<const geo::GeoFrame>> frame =
          FrameForField(registry, *spec.map, "waypoints_wgs84", "waypoints");
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
      spec.waypoints = *std::move(local);
      break;
    }
    case v1::EvaluateRiskRequest::kPolylineWgs84: {
      const auto& points = request.polyline_wgs84().points();
      if (points.size() < 2 || static_cast<size_t>(points.size()) > limits.max_waypoints) {
        return absl::InvalidArgumentError(
            absl::StrFormat("polyline_wgs84.points has %d points; it must have 2 to %d",
                            points.size(), limits.max_waypoints));
      }
      absl::StatusOr<std::shared_ptr<const geo::GeoFrame>> frame =
          FrameForField(registry, *spec.map, "polyline_wgs84", "polyline");
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
      spec.polyline.reserve(points.size());
      for (int i = 0; i < points.size(); ++i) {
        spec.polyline.push_back(Point3{(*local)[i].x, (*local)[i].y, points[i].alt_m()});
      }
      break;
    }
    default:
      return absl::InvalidArgumentError(
          "trajectory is required: set waypoints (poses) or polyline (points), or on a "
          "geo-referenced map waypoints_wgs84 or polyline_wgs84");
  }
  spec.frame = registry.Frame(spec.map->name());

  absl::StatusOr<ModelParams> params = ModelParamsFromProto(request.model_params());
  if (!params.ok()) return params.status();
  spec.params = *params;
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

namespace riskplan::server {
namespace {

// The map cells [i0, i1) x [j0, j1) that the local rectangle overlaps,
// clipped to the map; INVALID_ARGUMENT naming `field` when it overlaps none.
absl::Status WindowOfRect(const RiskMap& map, double x_min, double y_min, double x_max,
                          double y_max, const std::string& field, RiskLayerOptions* options) {
  // Indices computed in double and clipped before any conversion, so a far
  // rectangle cannot overflow an int.
  const double i0 = std::max(0.0, std::floor((x_min - map.x0()) / map.res()));
  const double j0 = std::max(0.0, std::floor((y_min - map.y0()) / map.res()));
  const double i1 = std::min<double>(map.nx(), std::ceil((x_max - map.x0()) / map.res()));
  const double j1 = std::min<double>(map.ny(), std::ceil((y_max - map.y0()) / map.res()));
  if (!(i1 > i0) || !(j1 > j0)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s x in [%g, %g], y in [%g, %g] does not overlap map '%s', which covers x in [%g, %g), "
        "y in [%g, %g)",
        field, x_min, x_max, y_min, y_max, map.name(), map.x0(), map.x0() + map.width_m(), map.y0(),
        map.y0() + map.height_m()));
  }
  options->first_column = static_cast<int>(i0);
  options->first_row = static_cast<int>(j0);
  options->columns = static_cast<int>(i1 - i0);
  options->rows = static_cast<int>(j1 - j0);
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<RiskLayerSpec> ValidateRiskLayerRequest(const v1::GetRiskLayerRequest& request,
                                                       const MapRegistry& registry,
                                                       const RequestLimits& limits) {
  RiskLayerSpec spec;
  absl::StatusOr<std::shared_ptr<const RiskMap>> map = FindMap(registry, request.map());
  if (!map.ok()) return map.status();
  spec.map = *std::move(map);
  spec.frame = registry.Frame(spec.map->name());
  const RiskMap& m = *spec.map;
  RiskLayerOptions& options = spec.options;
  options.threads = 1;  // the evaluation pool is the parallelism
  switch (request.area_case()) {
    case v1::GetRiskLayerRequest::kRegion: {
      const v1::LocalRect& r = request.region();
      for (auto [name, value] : {std::pair{"x_min_m", r.x_min_m()},
                                 {"y_min_m", r.y_min_m()},
                                 {"x_max_m", r.x_max_m()},
                                 {"y_max_m", r.y_max_m()}}) {
        if (absl::Status s = CheckFinite(value, absl::StrFormat("region.%s", name)); !s.ok()) {
          return s;
        }
      }
      if (!(r.x_min_m() < r.x_max_m()) || !(r.y_min_m() < r.y_max_m())) {
        return absl::InvalidArgumentError(absl::StrFormat(
            "region is x in [%g, %g], y in [%g, %g]; it needs x_min_m < x_max_m and y_min_m < "
            "y_max_m",
            r.x_min_m(), r.x_max_m(), r.y_min_m(), r.y_max_m()));
      }
      if (absl::Status s = WindowOfRect(m, r.x_min_m(), r.y_min_m(), r.x_max_m(), r.y_max_m(),
                                        "region", &options);
          !s.ok()) {
        return s;
      }
      break;
    }
    case v1::GetRiskLayerRequest::kRegionWgs84: {
      const v1::GeoRect& r = request.region_wgs84();
      absl::StatusOr<std::shared_ptr<const geo::GeoFrame>> frame =
          FrameForField(registry, m, "region_wgs84", "region");
      if (!frame.ok()) return frame.status();
      for (auto [name, value, limit] : {std::tuple{"south_lat_deg", r.south_lat_deg(), 90.0},
                                        {"north_lat_deg", r.north_lat_deg(), 90.0},
                                        {"west_lon_deg", r.west_lon_deg(), 180.0},
                                        {"east_lon_deg", r.east_lon_deg(), 180.0}}) {
        if (!(value >= -limit && value <= limit)) {
          return absl::InvalidArgumentError(absl::StrFormat(
              "region_wgs84.%s has value %g; it must be in [%g, %g]", name, value, -limit, limit));
        }
      }
      if (!(r.south_lat_deg() < r.north_lat_deg()) || !(r.west_lon_deg() < r.east_lon_deg())) {
        return absl::InvalidArgumentError(absl::StrFormat(
            "region_wgs84 is latitudes [%g, %g], longitudes [%g, %g]; it needs south < north "
            "and west < east",
            r.south_lat_deg(), r.north_lat_deg(), r.west_lon_deg(), r.east_lon_deg()));
      }
      // The box's edges, 65 points each, into the local frame: their local
      // bounding box is the region.
      constexpr int kPerEdge = 65;
      std::vector<geo::LatLon> edge;
      for (int k = 0; k < kPerEdge; ++k) {
        const double t = static_cast<double>(k) / (kPerEdge - 1);
        const double lat = r.south_lat_deg() + t * (r.north_lat_deg() - r.south_lat_deg());
        const double lon = r.west_lon_deg() + t * (r.east_lon_deg() - r.west_lon_deg());
        edge.push_back({r.south_lat_deg(), lon});
        edge.push_back({r.north_lat_deg(), lon});
        edge.push_back({lat, r.west_lon_deg()});
        edge.push_back({lat, r.east_lon_deg()});
      }
      absl::StatusOr<std::vector<geo::LocalXY>> local =
          PointsFromWgs84(**frame, edge, "region_wgs84");
      if (!local.ok()) return local.status();
      double x_min = (*local)[0].x, x_max = x_min, y_min = (*local)[0].y, y_max = y_min;
      for (const geo::LocalXY& p : *local) {
        x_min = std::min(x_min, p.x);
        x_max = std::max(x_max, p.x);
        y_min = std::min(y_min, p.y);
        y_max = std::max(y_max, p.y);
      }
      if (absl::Status s = WindowOfRect(m, x_min, y_min, x_max, y_max, "region_wgs84", &options);
          !s.ok()) {
        return s;
      }
      break;
    }
    default:
      break;  // the whole map
  }
  const int stride = request.stride() == 0 ? 1 : request.stride();
  if (stride < 1 || stride > 4096) {
    return absl::InvalidArgumentError(
        absl::StrFormat("stride has value %d; it must be in [1, 4096] (0: 1)", request.stride()));
  }
  options.stride = stride;
  const double height = request.height_agl_m() == 0.0 ? 100.0 : request.height_agl_m();
  if (!(std::isfinite(height) && height > 0.0 && height <= 10000.0)) {
    return absl::InvalidArgumentError(
        absl::StrFormat("height_agl_m has value %g; it must be finite and in (0, 10000] (0: 100)",
                        request.height_agl_m()));
  }
  options.height_agl_m = height;
  if (absl::Status s = CheckFinite(request.heading_rad(), "heading_rad"); !s.ok()) return s;
  options.heading_rad =
      request.max_over_headings() ? std::nan("") : NormalizeHeading(request.heading_rad());

  absl::StatusOr<ModelParams> params = ModelParamsFromProto(request.model_params());
  if (!params.ok()) return params.status();
  spec.params = *params;
  if (absl::Status s = CheckModelWork(spec.params, limits); !s.ok()) return s;

  absl::StatusOr<LayerShape> shape = LayerCells(m, options);
  if (!shape.ok()) return shape.status();
  spec.cells = static_cast<int64_t>(shape->nx) * shape->ny;
  const int64_t per_cell = request.max_over_headings() ? spec.params.heading_bins : 1;
  spec.evaluations = spec.cells * per_cell;
  if (spec.cells > kMaxRiskLayerCells || spec.evaluations > limits.max_risk_layer_evaluations) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "the risk layer of %d x %d cells (stride %d) needs %d configuration risks%s; the limits "
        "are %d cells and %d risks (--max_risk_layer_evaluations): ask for a smaller region or a "
        "larger stride",
        shape->nx, shape->ny, stride, spec.evaluations,
        request.max_over_headings()
            ? absl::StrFormat(" (%d heading bins each)", spec.params.heading_bins)
            : "",
        kMaxRiskLayerCells, limits.max_risk_layer_evaluations));
  }
  return spec;
}

}  // namespace riskplan::server
