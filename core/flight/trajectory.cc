#include "core/flight/trajectory.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "absl/strings/str_format.h"
#include "core/base/check.h"

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
    pieces.push_back(TrajectoryPiece::Manoeuvre(poses[i], poses[i + 1], params.GroundTurnRadius(),
                                                params.GroundClimbAngle()));
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
                                                        RiskEvaluator* evaluator,
                                                        const StopCondition& stop) {
  const ModelParams& params = model.params();
  TrajectoryEvaluation out;
  out.pieces.resize(pieces.size());
  DirectRiskEvaluator direct;
  RiskEvaluator* eval = evaluator != nullptr ? evaluator : &direct;

  std::vector<PieceRisk> rules;
  rules.reserve(pieces.size());
  double length_m = 0.0;
  for (size_t p = 0; p < pieces.size(); ++p) {
    const PieceRisk& rule = rules.emplace_back(pieces[p], params.sample_step_m, params);
    out.pieces[p].length_m = pieces[p].Length();
    out.pieces[p].parts = rule.parts();
    length_m += pieces[p].Length();
  }

  // Pieces are walked in order, each one's admissibility samples in order of
  // arc length (start, midpoints, end) and its midpoints' M summed in the
  // same order, whatever the batches. `checking` is the piece being walked;
  // `checked` its admissibility samples done so far.
  size_t checking = 0;
  int64_t checked = 0;
  double wind_time_s = 0.0;  // sum of the pieces' flight times
  double piece_start_m = 0.0;  // arc length at the start of piece `checking`
  // `m`, when given, is q's M as evaluated: for a midpoint it tells the
  // window rule without locating q again.
  auto check = [&](size_t p, const Pose& q, double s, const ConfigurationRisk* m = nullptr) {
    double limit = 0.0;
    const ViolationKind kind = m != nullptr ? model.CheckConfiguration(q, *m, &limit)
                                            : model.CheckConfiguration(q, &limit);
    if (kind == ViolationKind::kNone) return;
    out.pieces[p].admissible = false;
    out.admissible = false;
    if (!out.first_violation.has_value()) {
      out.first_violation = Violation{kind, q, piece_start_m + s, static_cast<int>(p), limit};
    }
  };
  // Checks the end of piece `checking` (and its start, if it had no
  // midpoint), adds its risk, and moves on to the next piece.
  auto finish_piece = [&]() {
    const PieceRisk& rule = rules[checking];
    if (checked == 0) check(checking, rule.AdmissibilitySample(0), 0.0);
    double s = 0.0;
    const Pose end = rule.AdmissibilitySample(rule.admissibility_samples() - 1, &s);
    check(checking, end, s);
    out.pieces[checking].risk = rule.Risk();
    out.pieces[checking].flight_time_s = rule.FlightTimeS();
    out.risk += out.pieces[checking].risk;
    wind_time_s += out.pieces[checking].flight_time_s;
    piece_start_m += pieces[checking].Length();
    ++checking;
    checked = 0;
  };

  // Midpoints in batches: piece `producing`, from midpoint `next`.
  size_t producing = 0;
  int64_t next = 0;
  std::vector<Pose> batch;
  std::vector<int32_t> batch_piece;  // the piece of each midpoint of the batch
  std::vector<ConfigurationRisk> risks;
  while (true) {
    batch.clear();
    batch_piece.clear();
    while (producing < pieces.size() && batch.size() < kEvaluationBatch) {
      const PieceRisk& rule = rules[producing];
      const int64_t end = std::min<int64_t>(
          rule.parts(), next + static_cast<int64_t>(kEvaluationBatch - batch.size()));
      rule.AppendMidpoints(next, end, &batch);
      batch_piece.resize(batch.size(), static_cast<int32_t>(producing));
      next = end;
      if (next == rule.parts()) {
        ++producing;
        next = 0;
      }
    }
    if (batch.empty()) break;
    if (stop.Reached()) return absl::CancelledError("evaluation stopped");
    risks.resize(batch.size());
    if (absl::Status s = eval->EvaluateBatch(model, batch, risks); !s.ok()) return s;
    for (size_t k = 0; k < batch.size(); ++k) {
      const size_t p = static_cast<size_t>(batch_piece[k]);
      while (checking < p) finish_piece();  // pieces before p are complete
      PieceRisk& rule = rules[p];
      if (checked == 0) {
        check(p, rule.AdmissibilitySample(0), 0.0);
        checked = 1;
      }
      // A midpoint is the very pose that was evaluated.
      const int64_t i = rule.added();
      const double s = rule.MidpointArc(i);
      rule.Add(risks[k], batch[k]);
      check(p, batch[k], s, &risks[k]);
      ++checked;
      if (options.keep_samples) {
        out.samples.push_back(
            SampleEvaluation{batch[k], piece_start_m + s, static_cast<int>(p), risks[k]});
      }
    }
  }
  while (checking < pieces.size()) finish_piece();
  out.length_m = length_m;
  // Still air: L / v of the whole length, as version 2 computed it.
  out.flight_time_s = params.Calm() ? FlightTimeS(length_m, params.airspeed_mps) : wind_time_s;
  return out;
}

double FlightTimeS(double length_m, double airspeed_mps) { return length_m / airspeed_mps; }

double RiskPerFlightHour(double risk, double flight_time_s) {
  if (!(flight_time_s > 0.0)) return 0.0;
  return risk / (flight_time_s / 3600.0);
}

int64_t PathPoseCount(double length_m, double step_m) {
  RISKPLAN_DCHECK(step_m > 0.0 && length_m >= 0.0);
  const double intervals = std::ceil(length_m / step_m);
  // 2^62: any larger count is refused by every caller's limit anyway.
  if (!(intervals < 4.6e18)) return std::numeric_limits<int64_t>::max();
  return static_cast<int64_t>(intervals) + 1;
}

std::vector<PathPose> SamplePath(std::span<const TrajectoryPiece> pieces, double step_m,
                                 size_t max_poses) {
  RISKPLAN_DCHECK(step_m > 0.0 && max_poses >= 2);
  std::vector<PathPose> out;
  if (pieces.empty()) return out;
  double total_m = 0.0;
  for (const TrajectoryPiece& piece : pieces) total_m += piece.Length();
  // Arc lengths are k * step_m (not a running sum, which would drift), each
  // looked up in the piece that holds it.
  size_t piece = 0;
  double piece_start_m = 0.0;
  for (int64_t k = 0; out.size() + 1 < max_poses; ++k) {
    const double s = static_cast<double>(k) * step_m;
    if (!(s < total_m)) break;
    while (piece + 1 < pieces.size() && s >= piece_start_m + pieces[piece].Length()) {
      piece_start_m += pieces[piece].Length();
      ++piece;
    }
    out.push_back(PathPose{pieces[piece].PoseAt(s - piece_start_m), s, static_cast<int>(piece)});
  }
  out.push_back(PathPose{pieces.back().End(), total_m, static_cast<int>(pieces.size() - 1)});
  return out;
}

}  // namespace riskplan
