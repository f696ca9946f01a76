#include "core/trajectory.h"

#include <cmath>
#include <limits>

#include "absl/strings/str_format.h"

namespace riskplan {

TrajectoryPiece TrajectoryPiece::Segment(const Point3& a, const Point3& b) {
  TrajectoryPiece p;
  p.is_segment_ = true;
  p.a_ = a;
  p.b_ = b;
  const double dx = b.x - a.x;
  const double dy = b.y - a.y;
  const double dz = b.z - a.z;
  p.heading_ = (dx == 0.0 && dy == 0.0) ? 0.0 : NormalizeHeading(std::atan2(dy, dx));
  p.length_m_ = std::sqrt(dx * dx + dy * dy + dz * dz);
  return p;
}

TrajectoryPiece TrajectoryPiece::Manoeuvre(const Pose& a, const Pose& b, double turn_radius_m,
                                           double max_climb_rad) {
  TrajectoryPiece p;
  p.is_segment_ = false;
  p.manoeuvre_ = DubinsAirplanePath(a, b, turn_radius_m, max_climb_rad);
  p.length_m_ = p.manoeuvre_.Length();
  return p;
}

Pose TrajectoryPiece::PoseAt(double s) const {
  if (!is_segment_) return manoeuvre_.PoseAt(s);
  if (length_m_ <= 0.0) return Pose{a_.x, a_.y, a_.z, heading_};
  const double f = std::clamp(s / length_m_, 0.0, 1.0);
  return Pose{a_.x + f * (b_.x - a_.x), a_.y + f * (b_.y - a_.y), a_.z + f * (b_.z - a_.z),
              heading_};
}

int PartCount(double length_m, double step_m) {
  if (!(length_m > 0.0)) return 0;
  return static_cast<int>(std::ceil(length_m / step_m));
}

void AppendMidpoints(const TrajectoryPiece& piece, double step_m, std::vector<Pose>* out) {
  const int k = PartCount(piece.Length(), step_m);
  const double ds = k > 0 ? piece.Length() / k : 0.0;
  for (int i = 0; i < k; ++i) out->push_back(piece.PoseAt((i + 0.5) * ds));
}

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
  std::vector<Pose> midpoints;
  std::vector<double> arc_lengths;
  std::vector<int> piece_of;
  double start_s = 0.0;
  for (size_t p = 0; p < pieces.size(); ++p) {
    const TrajectoryPiece& piece = pieces[p];
    const int k = PartCount(piece.Length(), params.sample_step_m);
    const double ds = k > 0 ? piece.Length() / k : 0.0;
    out.pieces[p].length_m = piece.Length();
    out.pieces[p].parts = k;
    for (int i = 0; i < k; ++i) {
      const double s = (i + 0.5) * ds;
      midpoints.push_back(piece.PoseAt(s));
      arc_lengths.push_back(start_s + s);
      piece_of.push_back(static_cast<int>(p));
    }
    start_s += piece.Length();
  }
  out.length_m = start_s;

  std::vector<ConfigurationRisk> risks(midpoints.size());
  DirectRiskEvaluator direct;
  RiskEvaluator* eval = evaluator != nullptr ? evaluator : &direct;
  if (absl::Status s = eval->EvaluateBatch(model, midpoints, risks); !s.ok()) return s;

  // Admissibility: for each piece its start, midpoints and end, by arc length.
  size_t cursor = 0;
  start_s = 0.0;
  auto check = [&](const Pose& q, double s, int piece) {
    double limit = 0.0;
    const ViolationKind kind = model.CheckConfiguration(q, &limit);
    if (kind == ViolationKind::kNone) return;
    out.pieces[piece].admissible = false;
    out.admissible = false;
    if (!out.first_violation.has_value()) {
      out.first_violation = Violation{kind, q, s, piece, limit};
    }
  };
  const double per_metre = params.failure_rate_per_s / params.airspeed_mps;
  for (size_t p = 0; p < pieces.size(); ++p) {
    const TrajectoryPiece& piece = pieces[p];
    const int k = out.pieces[p].parts;
    const double ds = k > 0 ? piece.Length() / k : 0.0;
    check(piece.Start(), start_s, static_cast<int>(p));
    double sum = 0.0;
    for (int i = 0; i < k; ++i, ++cursor) {
      check(midpoints[cursor], arc_lengths[cursor], static_cast<int>(p));
      if (risks[cursor].defined) sum += risks[cursor].risk;
    }
    check(piece.End(), start_s + piece.Length(), static_cast<int>(p));
    // lambda * sum M(q_k) * ds / v, with the common factor taken out of the sum.
    out.pieces[p].risk = per_metre * sum * ds;
    out.risk += out.pieces[p].risk;
    start_s += piece.Length();
  }

  if (options.keep_samples) {
    out.samples.reserve(midpoints.size());
    for (size_t i = 0; i < midpoints.size(); ++i) {
      out.samples.push_back(SampleEvaluation{midpoints[i], arc_lengths[i], piece_of[i], risks[i]});
    }
  }
  return out;
}

}  // namespace riskplan
