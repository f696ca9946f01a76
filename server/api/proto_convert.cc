#include "server/api/proto_convert.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <tuple>
#include <vector>

#include "absl/strings/str_format.h"
#include "core/base/check.h"
#include "core/base/wind.h"
#include "core/flight/piece_risk.h"

namespace riskplan::server {

void PoseToProto(const Pose& pose, v1::Pose* out) {
  out->set_x(pose.x);
  out->set_y(pose.y);
  out->set_z(pose.z);
  out->set_theta(pose.theta);
}

void GeoPoseToProto(const geo::GeoPose& pose, v1::GeoPose* out) {
  out->set_lat_deg(pose.lat_deg);
  out->set_lon_deg(pose.lon_deg);
  out->set_alt_m(pose.alt_m);
  out->set_heading_deg(pose.heading_deg);
}

std::vector<std::optional<geo::GeoPose>> ToWgs84Where(const geo::GeoFrame& frame,
                                                      std::span<const Pose> poses) {
  std::vector<std::optional<geo::GeoPose>> out(poses.size());
  std::vector<Pose> covered;
  std::vector<size_t> index;
  covered.reserve(poses.size());
  index.reserve(poses.size());
  for (size_t k = 0; k < poses.size(); ++k) {
    if (frame.Covers(poses[k].x, poses[k].y) && std::isfinite(poses[k].z) &&
        std::isfinite(poses[k].theta)) {
      covered.push_back(poses[k]);
      index.push_back(k);
    }
  }
  absl::StatusOr<std::vector<geo::GeoPose>> geo = frame.ToWgs84(covered);
  if (!geo.ok()) return out;
  for (size_t k = 0; k < index.size(); ++k) out[index[k]] = (*geo)[k];
  return out;
}

FlightHours FlightHoursOf(double risk, double flight_time_s) {
  return FlightHours{flight_time_s, RiskPerFlightHour(risk, flight_time_s)};
}

double PiecesFlightTimeS(std::span<const TrajectoryPiece> pieces, const ModelParams& params) {
  double length_m = 0.0;
  for (const TrajectoryPiece& piece : pieces) length_m += piece.Length();
  if (params.Calm()) return FlightTimeS(length_m, params.airspeed_mps);
  // EvaluateTrajectory's sum: each piece's PieceRisk time, in order (an
  // undefined M adds the time and no risk).
  double seconds = 0.0;
  for (const TrajectoryPiece& piece : pieces) {
    PieceRisk rule(piece, params.sample_step_m, params);
    for (int64_t k = 0; k < rule.parts(); ++k) rule.Add(ConfigurationRisk{}, rule.Midpoint(k));
    seconds += rule.FlightTimeS();
  }
  return seconds;
}

v1::ViolationKind ViolationKindToProto(ViolationKind kind) {
  switch (kind) {
    case ViolationKind::kNone:
      return v1::VIOLATION_KIND_UNSPECIFIED;
    case ViolationKind::kOutsideMap:
      return v1::OUTSIDE_MAP;
    case ViolationKind::kNoFlyZone:
      return v1::NO_FLY_ZONE;
    case ViolationKind::kTerrainCollision:
      return v1::TERRAIN_COLLISION;
    case ViolationKind::kBelowSafeAltitude:
      return v1::BELOW_SAFE_ALTITUDE;
    case ViolationKind::kAboveMaxAltitude:
      return v1::ABOVE_MAX_ALTITUDE;
    case ViolationKind::kImpactOutsideMap:
      return v1::IMPACT_OUTSIDE_MAP;
  }
  return v1::VIOLATION_KIND_UNSPECIFIED;
}

void EvaluationToProto(const TrajectoryEvaluation& evaluation, const ModelParams& params,
                       bool include_samples, const geo::GeoFrame* frame,
                       v1::EvaluateRiskResponse* out) {
  out->Clear();
  out->set_risk(evaluation.risk);
  out->set_length_m(evaluation.length_m);
  out->set_admissible(evaluation.admissible);
  const FlightHours hours = FlightHoursOf(evaluation.risk, evaluation.flight_time_s);
  out->set_flight_time_s(hours.flight_time_s);
  out->set_risk_per_flight_hour(hours.risk_per_flight_hour);
  out->set_airspeed_mps(params.airspeed_mps);
  if (evaluation.first_violation.has_value()) {
    const Violation& v = *evaluation.first_violation;
    v1::Violation* violation = out->mutable_first_violation();
    violation->set_kind(ViolationKindToProto(v.kind));
    PoseToProto(v.pose, violation->mutable_pose());
    if (frame != nullptr) {
      const std::optional<geo::GeoPose> geo = ToWgs84Where(*frame, {&v.pose, 1})[0];
      if (geo.has_value()) GeoPoseToProto(*geo, violation->mutable_pose_wgs84());
    }
    violation->set_arc_length_m(v.arc_length_m);
    violation->set_piece(v.piece);
    if (!std::isnan(v.limit_m)) violation->set_limit_m(v.limit_m);
    violation->set_message(v.ToString());
  }
  int64_t samples = 0;
  out->mutable_pieces()->Reserve(static_cast<int>(evaluation.pieces.size()));
  for (const PieceEvaluation& piece : evaluation.pieces) {
    v1::PieceEvaluation* p = out->add_pieces();
    p->set_risk(piece.risk);
    p->set_length_m(piece.length_m);
    p->set_parts(static_cast<int32_t>(piece.parts));  // bounded by --max_eval_samples
    p->set_admissible(piece.admissible);
    p->set_flight_time_s(piece.flight_time_s);
    samples += piece.parts;
  }
  out->set_sample_count(samples);
  if (!include_samples) return;
  // The caller evaluated with keep_samples; the count was bounded by
  // --max_response_samples before the evaluation (CheckSampleCount).
  out->mutable_samples()->Reserve(static_cast<int>(evaluation.samples.size()));
  const WindTriangle wind(params);
  std::vector<std::optional<geo::GeoPose>> geo;
  if (frame != nullptr) {
    std::vector<Pose> poses;
    poses.reserve(evaluation.samples.size());
    for (const SampleEvaluation& sample : evaluation.samples) poses.push_back(sample.pose);
    geo = ToWgs84Where(*frame, poses);
  }
  for (size_t k = 0; k < evaluation.samples.size(); ++k) {
    const SampleEvaluation& sample = evaluation.samples[k];
    v1::Sample* s = out->add_samples();
    if (!geo.empty() && geo[k].has_value()) GeoPoseToProto(*geo[k], s->mutable_wgs84());
    s->set_x(sample.pose.x);
    s->set_y(sample.pose.y);
    s->set_z(sample.pose.z);
    s->set_theta(sample.pose.theta);
    s->set_arc_length_m(sample.arc_length_m);
    s->set_piece(sample.piece);
    s->set_risk(sample.risk.risk);
    s->set_impact_factor(sample.risk.impact_factor);
    s->set_expected_shelter(sample.risk.expected_shelter);
    s->set_casualty_probability(sample.risk.casualty_probability);
    s->set_defined(sample.risk.defined);
    s->set_air_heading_rad(wind.AirHeading(sample.pose.theta));
    s->set_ground_speed_mps(wind.GroundSpeed(sample.pose.theta));
  }
}

void PathToProto(std::span<const PathPose> path, std::span<const ConfigurationRisk> risks,
                 const RiskMap& map, const ModelParams& params, const geo::GeoFrame* frame,
                 v1::EvaluateRiskResponse* out) {
  const WindTriangle wind(params);
  RISKPLAN_DCHECK(risks.size() == path.size());
  std::vector<std::optional<geo::GeoPose>> geo;
  if (frame != nullptr) {
    std::vector<Pose> poses;
    poses.reserve(path.size());
    for (const PathPose& p : path) poses.push_back(p.pose);
    geo = ToWgs84Where(*frame, poses);
  }
  out->mutable_path()->Reserve(static_cast<int>(path.size()));
  for (size_t k = 0; k < path.size(); ++k) {
    v1::PathSample* s = out->add_path();
    PoseToProto(path[k].pose, s->mutable_pose());
    if (!geo.empty() && geo[k].has_value()) GeoPoseToProto(*geo[k], s->mutable_wgs84());
    s->set_arc_length_m(path[k].arc_length_m);
    s->set_piece(path[k].piece);
    s->set_defined(risks[k].defined);
    s->set_risk(risks[k].defined ? risks[k].risk : 0.0);
    s->set_air_heading_rad(wind.AirHeading(path[k].pose.theta));
    s->set_ground_speed_mps(wind.GroundSpeed(path[k].pose.theta));
    int i = 0, j = 0;
    s->set_terrain_m(map.CellOf(path[k].pose.x, path[k].pose.y, &i, &j)
                         ? static_cast<double>(map.terrain(i, j))
                         : std::nan(""));
  }
}

void FeasibilityToProto(const FeasibilityResult& result, const geo::GeoFrame* frame,
                        v1::TwoTierResult* out) {
  out->Clear();
  out->set_feasible(result.feasible);
  out->set_cells_checked(result.cells_checked);
  if (result.feasible) {
    out->set_segment(-1);
    out->set_cell_i(-1);
    out->set_cell_j(-1);
    return;
  }
  switch (result.tier) {
    case FeasibilityTier::kNone:
      out->set_tier(v1::FEASIBILITY_TIER_UNSPECIFIED);
      break;
    case FeasibilityTier::kDetailed:
      out->set_tier(v1::DETAILED);
      break;
    case FeasibilityTier::kCoarse:
      out->set_tier(v1::COARSE);
      break;
  }
  out->set_segment(result.segment);
  out->set_cell_i(result.cell_i);
  out->set_cell_j(result.cell_j);
  out->mutable_position()->set_x(result.position.x);
  out->mutable_position()->set_y(result.position.y);
  out->mutable_position()->set_z(result.position.z);
  out->set_kind(ViolationKindToProto(result.kind));
  if (frame != nullptr) {
    const Pose p{result.position.x, result.position.y, result.position.z, 0.0};
    const std::optional<geo::GeoPose> geo = ToWgs84Where(*frame, {&p, 1})[0];
    if (geo.has_value()) {
      out->mutable_position_wgs84()->set_lat_deg(geo->lat_deg);
      out->mutable_position_wgs84()->set_lon_deg(geo->lon_deg);
      out->mutable_position_wgs84()->set_alt_m(geo->alt_m);
    }
  }
}

absl::Status TrajectoryToProto(const PlanImprovement& improvement, const ModelParams& params,
                               double display_step_m, const geo::GeoFrame* frame,
                               v1::Trajectory* out) {
  out->Clear();
  for (const Pose& pose : improvement.waypoints) PoseToProto(pose, out->add_waypoints());
  out->set_risk(improvement.risk);
  out->set_length_m(improvement.length_m);
  out->set_found_at_iteration(improvement.iterations);
  out->set_found_at_s(improvement.elapsed_s);
  out->set_replanned(improvement.replanned);

  absl::StatusOr<std::vector<TrajectoryPiece>> pieces =
      PiecesFromWaypoints(improvement.waypoints, params);
  if (!pieces.ok()) return pieces.status();
  // Still air: length / v from the planner's length, as before; in wind the
  // evaluation's sum over the same midpoints.
  const FlightHours hours = FlightHoursOf(
      improvement.risk, params.Calm() ? FlightTimeS(improvement.length_m, params.airspeed_mps)
                                      : PiecesFlightTimeS(*pieces, params));
  out->set_flight_time_s(hours.flight_time_s);
  out->set_risk_per_flight_hour(hours.risk_per_flight_hour);
  double total_m = 0.0;
  for (const TrajectoryPiece& piece : *pieces) total_m += piece.Length();
  // The step grows with the path so that a long trajectory still fits in
  // kMaxDisplayPathPoses poses (the message and the client's picture stay
  // bounded); SamplePath's own bound is a guard against rounding.
  const double step_m = std::max(display_step_m, total_m / (kMaxDisplayPathPoses - 1));
  const std::vector<PathPose> path = SamplePath(*pieces, step_m, kMaxDisplayPathPoses);
  out->mutable_path()->Reserve(static_cast<int>(path.size()));
  const WindTriangle wind(params);
  out->mutable_path_air_heading_rad()->Reserve(static_cast<int>(path.size()));
  out->mutable_path_ground_speed_mps()->Reserve(static_cast<int>(path.size()));
  for (const PathPose& p : path) {
    PoseToProto(p.pose, out->add_path());
    out->add_path_air_heading_rad(wind.AirHeading(p.pose.theta));
    out->add_path_ground_speed_mps(wind.GroundSpeed(p.pose.theta));
  }
  if (frame != nullptr) {
    // Both lists in one batch, so that the PROJ set-up is paid once.
    std::vector<Pose> poses(improvement.waypoints.begin(), improvement.waypoints.end());
    for (const PathPose& p : path) poses.push_back(p.pose);
    const std::vector<std::optional<geo::GeoPose>> geo = ToWgs84Where(*frame, poses);
    const size_t waypoints = improvement.waypoints.size();
    // Planned poses lie inside the map, so every one converts; if PROJ
    // failed, both lists are left empty rather than misaligned.
    bool all = true;
    for (const auto& g : geo) all = all && g.has_value();
    if (all) {
      for (size_t k = 0; k < geo.size(); ++k) {
        GeoPoseToProto(*geo[k], k < waypoints ? out->add_waypoints_wgs84() : out->add_path_wgs84());
      }
    }
  }
  return absl::OkStatus();
}

namespace {

// PlanUpdate.front: each point as a Trajectory (its path sampled for drawing).
absl::Status FrontToProto(const std::vector<FrontPoint>& front, const ModelParams& params,
                          double display_step_m, const geo::GeoFrame* frame,
                          v1::PlanUpdate* update) {
  for (size_t k = 0; k < front.size(); ++k) {
    const FrontPoint& p = front[k];
    PlanImprovement point;
    point.waypoints = p.waypoints;
    point.risk = p.risk;
    point.length_m = p.length_m;
    point.flight_time_s = p.flight_time_s;
    point.iterations = p.found_at_iteration;
    point.elapsed_s = p.found_at_s;
    if (absl::Status s = TrajectoryToProto(point, params, display_step_m, frame,
                                           update->add_front());
        !s.ok()) {
      return absl::InternalError(absl::StrFormat(
          "front[%d] (%d waypoints) cannot be converted: %s", k, p.waypoints.size(), s.message()));
    }
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<v1::PlanUpdate> ImprovementToProto(const PlanImprovement& improvement,
                                                  const ModelParams& params, double display_step_m,
                                                  const geo::GeoFrame* frame) {
  v1::PlanUpdate update;
  update.set_elapsed_s(improvement.elapsed_s);
  update.set_iterations(improvement.iterations);
  update.set_tree_size(improvement.tree_size);
  if (absl::Status s = TrajectoryToProto(improvement, params, display_step_m, frame,
                                         update.mutable_trajectory());
      !s.ok()) {
    return absl::InternalError(
        absl::StrFormat("the trajectory of the improvement found at iteration %d (%d waypoints) "
                        "cannot be converted: %s",
                        improvement.iterations, improvement.waypoints.size(), s.message()));
  }
  if (absl::Status s = FrontToProto(improvement.front, params, display_step_m, frame, &update);
      !s.ok()) {
    return s;
  }
  return update;
}

absl::StatusOr<v1::PlanUpdate> FinalUpdateToProto(const PlanResult& result,
                                                  v1::EndReason end_reason,
                                                  const ModelParams& params, double display_step_m,
                                                  bool include_tree, const geo::GeoFrame* frame) {
  v1::PlanUpdate update;
  update.set_final(true);
  update.set_end_reason(end_reason);
  update.set_elapsed_s(result.elapsed_s);
  update.set_iterations(result.iterations);
  update.set_tree_size(result.tree_size);
  update.set_configurations_evaluated(result.configurations_evaluated);
  if (result.best.has_value()) {
    if (absl::Status s = TrajectoryToProto(*result.best, params, display_step_m, frame,
                                           update.mutable_trajectory());
        !s.ok()) {
      return absl::InternalError(absl::StrFormat(
          "the final message's best trajectory (found at iteration %d, %d waypoints) cannot be "
          "converted: %s",
          result.best->iterations, result.best->waypoints.size(), s.message()));
    }
  }
  if (absl::Status s = FrontToProto(result.front, params, display_step_m, frame, &update);
      !s.ok()) {
    return s;
  }
  if (result.limits.candidates > 0 || !result.limits.note.empty()) {
    v1::LimitReport* report = update.mutable_limits();
    report->set_note(result.limits.note);
    report->set_candidates(result.limits.candidates);
    report->set_rejected(result.limits.rejected);
    report->set_fastest_flight_time_s(result.limits.fastest_flight_time_s.value_or(0.0));
    report->set_shortest_length_m(result.limits.shortest_length_m.value_or(0.0));
    report->set_lowest_risk(result.limits.lowest_risk.value_or(0.0));
    report->set_lowest_risk_per_flight_hour(
        result.limits.lowest_risk_per_flight_hour.value_or(0.0));
  }
  if (include_tree) {
    // Bounded (docs/api.md): a long plan's tree can have millions of edges;
    // 50,000 of them (about 4 MB) stay well inside the 64 MiB message limit
    // of the server's sends and riskplan_client's receives.
    const size_t edges = std::min(result.tree.size(), kMaxTreeEdges);
    update.mutable_tree_edges()->Reserve(static_cast<int>(edges));
    for (size_t i = 0; i < edges; ++i) {
      v1::TreeEdge* edge = update.add_tree_edges();
      PoseToProto(result.tree[i].from, edge->mutable_from());
      PoseToProto(result.tree[i].to, edge->mutable_to());
    }
    if (frame != nullptr && edges > 0) {
      // Positions only (a drawing aid): one PROJ inversion a point.
      std::vector<geo::LocalXY> points;
      points.reserve(2 * edges);
      for (size_t i = 0; i < edges; ++i) {
        points.push_back({result.tree[i].from.x, result.tree[i].from.y});
        points.push_back({result.tree[i].to.x, result.tree[i].to.y});
      }
      absl::StatusOr<std::vector<geo::LatLon>> geo = frame->ToWgs84(points);
      if (geo.ok()) {
        for (size_t i = 0; i < edges; ++i) {
          v1::TreeEdge* edge = update.mutable_tree_edges(static_cast<int>(i));
          for (auto [ll, z, out] :
               {std::tuple{(*geo)[2 * i], result.tree[i].from.z, edge->mutable_from_wgs84()},
                std::tuple{(*geo)[2 * i + 1], result.tree[i].to.z, edge->mutable_to_wgs84()}}) {
            out->set_lat_deg(ll.lat_deg);
            out->set_lon_deg(ll.lon_deg);
            out->set_alt_m(z);
          }
        }
      }
    }
    update.set_tree_truncated(result.tree.size() > edges);
  }
  return update;
}

bool BoundsToProto(const geo::GeoFrame& frame, double x_min, double y_min, double x_max,
                   double y_max, v1::GeoBounds* out) {
  absl::StatusOr<geo::GeoBounds> b = frame.BoundsOf(x_min, y_min, x_max, y_max);
  if (!b.ok()) return false;
  out->Clear();
  for (const geo::LatLon& c : b->corners) {
    v1::GeoPoint2* p = out->add_corners();
    p->set_lat_deg(c.lat_deg);
    p->set_lon_deg(c.lon_deg);
  }
  out->set_min_lat_deg(b->min_lat_deg);
  out->set_max_lat_deg(b->max_lat_deg);
  out->set_min_lon_deg(b->min_lon_deg);
  out->set_max_lon_deg(b->max_lon_deg);
  return true;
}

v1::MapInfo MapInfoFromMap(const RiskMap& map, const geo::GeoFrame* frame) {
  v1::MapInfo info;
  info.set_name(map.name());
  info.set_x0_m(map.x0());
  info.set_y0_m(map.y0());
  info.set_width_m(map.width_m());
  info.set_height_m(map.height_m());
  info.set_resolution_m(map.res());
  info.set_nx(map.nx());
  info.set_ny(map.ny());
  for (const char* layer : {"density", "shelter", "terrain", "nofly", "glide_altitude"}) {
    info.add_layers(layer);
  }
  for (const LandingSite& site : map.landing_sites()) {
    v1::LandingSite* s = info.add_landing_sites();
    s->set_name(site.name);
    s->set_i(site.i);
    s->set_j(site.j);
    s->set_x(map.x0() + (site.i + 0.5) * map.res());
    s->set_y(map.y0() + (site.j + 0.5) * map.res());
    s->set_terrain_m(map.terrain(site.i, site.j));
  }
  info.set_provenance(map.header().provenance);
  if (map.header().geo.has_value()) {
    info.mutable_geo()->set_origin_lat_deg(map.header().geo->origin_lat_deg);
    info.mutable_geo()->set_origin_lon_deg(map.header().geo->origin_lon_deg);
    info.mutable_geo()->set_crs(map.header().geo->crs);
    info.mutable_geo()->set_origin_x_m(map.x0());
    info.mutable_geo()->set_origin_y_m(map.y0());
  }
  if (frame != nullptr) {
    info.mutable_geo()->set_proj_definition(frame->proj_definition());
    BoundsToProto(*frame, map.x0(), map.y0(), map.x0() + map.width_m(), map.y0() + map.height_m(),
                  info.mutable_bounds_wgs84());
    std::vector<geo::LocalXY> sites;
    for (const v1::LandingSite& site : info.landing_sites()) sites.push_back({site.x(), site.y()});
    absl::StatusOr<std::vector<geo::LatLon>> geo = frame->ToWgs84(sites);
    if (geo.ok()) {
      for (size_t k = 0; k < geo->size(); ++k) {
        v1::GeoPoint2* p = info.mutable_landing_sites(static_cast<int>(k))->mutable_wgs84();
        p->set_lat_deg((*geo)[k].lat_deg);
        p->set_lon_deg((*geo)[k].lon_deg);
      }
    }
  }
  const std::vector<float>& terrain = map.layers().terrain;
  if (!terrain.empty()) {
    const auto [lo, hi] = std::minmax_element(terrain.begin(), terrain.end());
    info.set_terrain_min_m(*lo);
    info.set_terrain_max_m(*hi);
  }
  info.set_memory_bytes(static_cast<int64_t>(map.MemoryBytes()));
  return info;
}

v1::GetMapLayerResponse DownsampleLayer(const RiskMap& map, v1::MapLayer layer,
                                        int max_side_cells) {
  RISKPLAN_DCHECK(max_side_cells >= 1);
  RISKPLAN_DCHECK(layer == v1::POPULATION_DENSITY || layer == v1::SHELTER || layer == v1::TERRAIN ||
                  layer == v1::NO_FLY);
  const int side = std::max(map.nx(), map.ny());
  const int factor = std::max(1, (side + max_side_cells - 1) / max_side_cells);
  const int nx = (map.nx() + factor - 1) / factor;
  const int ny = (map.ny() + factor - 1) / factor;
  v1::GetMapLayerResponse out;
  out.set_map(map.name());
  out.set_layer(layer);
  out.set_x0_m(map.x0());
  out.set_y0_m(map.y0());
  out.set_cell_m(map.res() * factor);
  out.set_nx(nx);
  out.set_ny(ny);
  out.set_factor(factor);
  out.mutable_values()->Resize(nx * ny, 0.0f);
  float* values = out.mutable_values()->mutable_data();
  // Written at bj * nx + bi with bi < nx, bj < ny below.
  RISKPLAN_DCHECK(out.values_size() == nx * ny);
  for (int bj = 0; bj < ny; ++bj) {
    for (int bi = 0; bi < nx; ++bi) {
      double sum = 0.0;
      int count = 0;
      bool any_nofly = false;
      for (int j = bj * factor; j < std::min(map.ny(), (bj + 1) * factor); ++j) {
        for (int i = bi * factor; i < std::min(map.nx(), (bi + 1) * factor); ++i) {
          switch (layer) {
            case v1::POPULATION_DENSITY:
              sum += map.density(i, j);
              break;
            case v1::SHELTER:
              sum += map.shelter(i, j);
              break;
            case v1::TERRAIN:
              sum += map.terrain(i, j);
              break;
            default:
              any_nofly = any_nofly || map.nofly(i, j);
              break;
          }
          ++count;
        }
      }
      // A block is no-fly if any of its cells is, so a downsampled picture
      // never hides a no-fly cell; the other layers are averaged.
      values[bj * nx + bi] = layer == v1::NO_FLY ? (any_nofly ? 1.0f : 0.0f)
                                                 : static_cast<float>(sum / std::max(count, 1));
    }
  }
  return out;
}

v1::GetRiskLayerResponse RiskLayerToProto(const RiskLayer& layer, const RiskMap& map,
                                          const RiskLayerOptions& options,
                                          const geo::GeoFrame* frame) {
  v1::GetRiskLayerResponse out;
  out.set_map(map.name());
  out.set_x0_m(layer.x0);
  out.set_y0_m(layer.y0);
  out.set_cell_m(layer.res_m);
  out.set_nx(layer.nx);
  out.set_ny(layer.ny);
  out.set_stride(options.stride);
  out.set_first_column(options.first_column);
  out.set_first_row(options.first_row);
  out.set_height_agl_m(options.height_agl_m);
  const bool max_over_headings = std::isnan(options.heading_rad);
  out.set_max_over_headings(max_over_headings);
  out.set_heading_rad(max_over_headings ? 0.0 : options.heading_rad);
  out.mutable_risk()->Assign(layer.risk.begin(), layer.risk.end());
  out.set_evaluations(layer.evaluations);
  if (frame != nullptr) {
    BoundsToProto(*frame, layer.x0, layer.y0, layer.x0 + layer.nx * layer.res_m,
                  layer.y0 + layer.ny * layer.res_m, out.mutable_bounds_wgs84());
  }
  return out;
}

v1::EndReason EndReasonToProto(StopReason reason, bool stopped_by_shutdown) {
  // A plan the shutdown cut short says so, whether or not it had a solution.
  if (stopped_by_shutdown &&
      (reason == StopReason::kCancelled || reason == StopReason::kNoSolution)) {
    return v1::SHUTDOWN;
  }
  switch (reason) {
    case StopReason::kBudgetExhausted:
      return v1::BUDGET_EXHAUSTED;
    case StopReason::kConverged:
      return v1::CONVERGED;
    case StopReason::kCancelled:
      return v1::CANCELLED;
    case StopReason::kNoSolution:
      return v1::NO_SOLUTION;
  }
  return v1::END_REASON_UNSPECIFIED;
}

}  // namespace riskplan::server
