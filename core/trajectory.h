// Trajectories and their risk (spec sections 4 and 6).
//
// A trajectory is a sequence of pieces: straight segments (polyline input) or
// Dubins-airplane manoeuvres (waypoint input). Each piece of 3-D length L is
// cut into K = ceil(L / d_step) equal parts; M is taken at each part's
// midpoint, and admissibility is checked at those midpoints plus both end
// points of the piece.
#ifndef RISKPLAN_CORE_TRAJECTORY_H_
#define RISKPLAN_CORE_TRAJECTORY_H_

#include <optional>
#include <span>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/dubins.h"
#include "core/geometry.h"
#include "core/risk_evaluator.h"
#include "core/risk_model.h"

namespace riskplan {

// One piece of a trajectory, parameterised by 3-D arc length.
class TrajectoryPiece {
 public:
  // A straight segment; its heading is atan2(dy, dx) (0 for a vertical one).
  static TrajectoryPiece Segment(const Point3& a, const Point3& b);
  // A Dubins-airplane manoeuvre between two poses.
  static TrajectoryPiece Manoeuvre(const Pose& a, const Pose& b, double turn_radius_m,
                                   double max_climb_rad);

  bool is_segment() const { return is_segment_; }
  double Length() const { return length_m_; }
  // Pose after 3-D arc length s in [0, Length()] (clamped).
  Pose PoseAt(double s) const;
  Pose Start() const { return PoseAt(0.0); }
  Pose End() const { return PoseAt(length_m_); }
  // REQUIRES: !is_segment().
  const DubinsAirplanePath& manoeuvre() const { return manoeuvre_; }

 private:
  bool is_segment_ = true;
  Point3 a_;
  Point3 b_;
  double heading_ = 0.0;
  DubinsAirplanePath manoeuvre_;
  double length_m_ = 0.0;
};

// K = ceil(L / step) parts (0 for a piece of length 0).
int PartCount(double length_m, double step_m);

// Appends the K midpoint configurations of `piece` (spec section 4) to `out`.
void AppendMidpoints(const TrajectoryPiece& piece, double step_m, std::vector<Pose>* out);

// Builds pieces from input, rejecting (InvalidArgument, naming the index and
// the value) fewer than 2 points, non-finite coordinates and more than
// `max_points` points. Headings of waypoints are normalised to [0, 2 pi).
absl::StatusOr<std::vector<TrajectoryPiece>> PiecesFromWaypoints(std::span<const Pose> waypoints,
                                                                 const ModelParams& params,
                                                                 size_t max_points = 100000);
absl::StatusOr<std::vector<TrajectoryPiece>> PiecesFromPolyline(std::span<const Point3> points,
                                                                size_t max_points = 100000);

// The first sample, in order of arc length, that breaks a rule of spec section 6.
struct Violation {
  ViolationKind kind = ViolationKind::kNone;
  Pose pose;                  // where
  double arc_length_m = 0.0;  // from the start of the trajectory
  int piece = 0;              // index of the piece
  double limit_m = 0.0;       // altitude limit broken (NaN when the kind has none)
  // E.g. "BELOW_SAFE_ALTITUDE at (1200.0, 3400.0, 160.0) m, arc length 812.5 m
  // (piece 2): altitude 160.0 m < safe altitude 171.3 m".
  std::string ToString() const;
};

struct PieceEvaluation {
  double risk = 0.0;      // lambda * sum M * ds / v over defined samples
  double length_m = 0.0;  // 3-D length
  int parts = 0;          // K
  bool admissible = true;
};

struct SampleEvaluation {
  Pose pose;
  double arc_length_m = 0.0;  // from the start of the trajectory
  int piece = 0;
  ConfigurationRisk risk;
};

struct TrajectoryEvaluation {
  // Sum of piece risks (expected casualties per flight). Where a sample's M is
  // undefined (outside the map, at or below terrain) it adds nothing; such a
  // trajectory is never admissible, and a planner treats it as infinite risk.
  double risk = 0.0;
  double length_m = 0.0;
  bool admissible = true;
  std::optional<Violation> first_violation;
  std::vector<PieceEvaluation> pieces;
  std::vector<SampleEvaluation> samples;  // only when asked for
};

struct EvaluationOptions {
  bool keep_samples = false;
};

// Evaluates the risk, length and admissibility of `pieces`. The configuration
// risks are computed in one batch through `evaluator` (DirectRiskEvaluator when
// null). Fails only when the evaluator does.
absl::StatusOr<TrajectoryEvaluation> EvaluateTrajectory(const RiskModel& model,
                                                        std::span<const TrajectoryPiece> pieces,
                                                        const EvaluationOptions& options = {},
                                                        RiskEvaluator* evaluator = nullptr);

}  // namespace riskplan

#endif  // RISKPLAN_CORE_TRAJECTORY_H_
