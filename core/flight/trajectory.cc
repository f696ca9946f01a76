#include "core/flight/trajectory.h"

#include <cmath>
#include <limits>

#include "absl/strings/str_format.h"

namespace riskplan {

namespace {

absl::Status CheckCount(size_t n, size_t max_points, const char* what) {
  if (n < 2) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s: %d given; a trajectory needs at least 2", what, n));
  }
  if (n > max_points) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s: %d given; at most %d are accepted", what, n, max_points));
  }
  return absl::OkStatus();
}

absl::Status CheckFinite(const char* what, size_t index, const char* field, double value) {
  if (std::isfinite(value)) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrFormat("%s[%d].%s is %g; coordinates must be finite", what, index, field, value));
}

}  // namespace

absl::StatusOr<std::vector<TrajectoryPiece>> PiecesFromWaypoints(std::span<const Pose> waypoints,
                                                                 const ModelParams& params,
                                                                 size_t max_points) {
  if (absl::Status s = CheckCount(waypoints.size(), max_points, "waypoints"); !s.ok()) return s;
  std::vector<Pose> poses(waypoints.begin(), waypoints.end());
  for (size_t i = 0; i < poses.size(); ++i) {
    const Pose& p = poses[i];
    for (auto [field, value] : {std::pair{"x", p.x}, {"y", p.y}, {"z", p.z}, {"theta", p.theta}}) {
      if (absl::Status s = CheckFinite("waypoints", i, field, value); !s.ok()) return s;
    }
    poses[i].theta = NormalizeHeading(p.theta);
  }
  std::vector<TrajectoryPiece> pieces;
  pieces.reserve(poses.size() - 1);
  for (size_t i = 0; i + 1 < poses.size(); ++i) {
    pieces.push_back(TrajectoryPiece::Manoeuvre(poses[i], poses[i + 1], params.turn_radius_m,
                                                params.max_climb_rad));
  }
  return pieces;
}

absl::StatusOr<std::vector<TrajectoryPiece>> PiecesFromPolyline(std::span<const Point3> points,
                                                                size_t max_points) {
  if (absl::Status s = CheckCount(points.size(), max_points, "polyline points"); !s.ok()) return s;
  for (size_t i = 0; i < points.size(); ++i) {
    const Point3& p = points[i];
    for (auto [field, value] : {std::pair{"x", p.x}, {"y", p.y}, {"z", p.z}}) {
      if (absl::Status s = CheckFinite("points", i, field, value); !s.ok()) return s;
    }
  }
  std::vector<TrajectoryPiece> pieces;
  pieces.reserve(points.size() - 1);
  for (size_t i = 0; i + 1 < points.size(); ++i) {
    pieces.push_back(TrajectoryPiece::Segment(points[i], points[i + 1]));
  }
  return pieces;
}

std::string Violation::ToString() const {
  std::string where =
      absl::StrFormat("%s at (%.1f, %.1f, %.1f) m, arc length %.1f m (piece %d)",
                      ViolationKindName(kind), pose.x, pose.y, pose.z, arc_length_m, piece);
  switch (kind) {
    case ViolationKind::kTerrainCollision:
      return where + absl::StrFormat(": altitude %.1f m <= terrain %.1f m", pose.z, limit_m);
    case ViolationKind::kBelowSafeAltitude:
      if (std::isinf(limit_m)) return where + ": no landing site can be reached by a glide";
      return where + absl::StrFormat(": altitude %.1f m < safe altitude %.1f m", pose.z, limit_m);
    case ViolationKind::kAboveMaxAltitude:
      return where + absl::StrFormat(": altitude %.1f m > ceiling %.1f m (terrain + max_agl)",
                                     pose.z, limit_m);
    case ViolationKind::kImpactOutsideMap:
      return where +
             ": the impact window of a fall from here reaches past the map's edge, where the "
             "ground is unknown";
    default:
      return where;
  }
}

absl::StatusOr<TrajectoryEvaluation> EvaluateTrajectory(const RiskModel& model,
                                                        std::span<const TrajectoryPiece> pieces,
                                                        const EvaluationOptions& options,
                                                        RiskEvaluator* evaluator) {
  const ModelParams& params = model.params();
  TrajectoryEvaluation out;
  out.pieces.resize(pieces.size());

  // Midpoints of every piece, in order, in one batch.
  std::vector<PieceRisk> rules;
  rules.reserve(pieces.size());
  std::vector<Pose> midpoints;
  for (size_t p = 0; p < pieces.size(); ++p) {
    const PieceRisk& rule = rules.emplace_back(pieces[p], params.sample_step_m, params);
    out.pieces[p].length_m = pieces[p].Length();
    out.pieces[p].parts = rule.parts();
    rule.AppendMidpoints(0, rule.parts(), &midpoints);
  }

  std::vector<ConfigurationRisk> risks(midpoints.size());
  DirectRiskEvaluator direct;
  RiskEvaluator* eval = evaluator != nullptr ? evaluator : &direct;
  if (absl::Status s = eval->EvaluateBatch(model, midpoints, risks); !s.ok()) return s;

  // Risk and admissibility, piece by piece: the admissibility samples in
  // order of arc length (start, midpoints, end), the midpoints' M summed in
  // the same order.
  size_t cursor = 0;
  double start_s = 0.0;
  for (size_t p = 0; p < pieces.size(); ++p) {
    PieceRisk& rule = rules[p];
    const int piece = static_cast<int>(p);
    const size_t first_midpoint = cursor;
    for (int64_t i = 0; i < rule.admissibility_samples(); ++i) {
      double s = 0.0;
      double limit = 0.0;
      ViolationKind kind = ViolationKind::kNone;
      Pose q;
      if (i >= 1 && i <= rule.parts()) {
        // A midpoint is the very pose that was evaluated: its M tells the
        // window rule without locating it again.
        q = midpoints[cursor];
        s = rule.MidpointArc(i - 1);
        rule.Add(risks[cursor]);
        kind = model.CheckConfiguration(q, risks[cursor], &limit);
        ++cursor;
      } else {
        q = rule.AdmissibilitySample(i, &s);
        kind = model.CheckConfiguration(q, &limit);
      }
      if (kind == ViolationKind::kNone) continue;
      out.pieces[p].admissible = false;
      out.admissible = false;
      if (!out.first_violation.has_value()) {
        out.first_violation = Violation{kind, q, start_s + s, piece, limit};
      }
    }
    out.pieces[p].risk = rule.Risk();
    out.risk += out.pieces[p].risk;
    if (options.keep_samples) {
      for (size_t k = first_midpoint; k < cursor; ++k) {
        out.samples.push_back(SampleEvaluation{
            midpoints[k], start_s + rule.MidpointArc(static_cast<int64_t>(k - first_midpoint)),
            piece, risks[k]});
      }
    }
    start_s += pieces[p].Length();
  }
  out.length_m = start_s;
  return out;
}

}  // namespace riskplan
