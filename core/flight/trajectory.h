// Trajectories and their risk (spec sections 4 and 6).
//
// A trajectory is a sequence of pieces (core/flight/trajectory_piece.h):
// straight segments (polyline input) or Dubins-airplane manoeuvres (waypoint
// input). Each piece is sampled, summed and checked by the one piece-risk
// rule, PieceRisk (core/flight/piece_risk.h).
#ifndef RISKPLAN_CORE_FLIGHT_TRAJECTORY_H_
#define RISKPLAN_CORE_FLIGHT_TRAJECTORY_H_

#include <optional>
#include <span>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/cancellation.h"
#include "core/base/geometry.h"
#include "core/flight/piece_risk.h"
#include "core/flight/trajectory_piece.h"
#include "core/risk/risk_evaluator.h"
#include "core/risk/risk_model.h"

namespace riskplan {

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
  double flight_time_s = 0.0;  // spec section 4: L / v in still air, sum(ds / gs) in wind
  int64_t parts = 0;      // K
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
  // undefined (outside the map, at or below terrain, impact window past the
  // map) it adds nothing; such a trajectory is never admissible, and a
  // planner treats it as infinite risk.
  double risk = 0.0;
  double length_m = 0.0;
  // Spec section 4: FlightTimeS(length_m, v) in still air (version 2), the
  // sum of ds / gs(theta_k) over every midpoint in wind.
  double flight_time_s = 0.0;
  bool admissible = true;
  std::optional<Violation> first_violation;
  std::vector<PieceEvaluation> pieces;
  std::vector<SampleEvaluation> samples;  // only when asked for
};

struct EvaluationOptions {
  bool keep_samples = false;
};

// Midpoints per risk batch of EvaluateTrajectory: a trajectory of more
// samples is evaluated in several batches (same results, bounded memory).
inline constexpr size_t kEvaluationBatch = size_t{1} << 16;

// Evaluates the risk, length and admissibility of `pieces`. The configuration
// risks are computed through `evaluator` (DirectRiskEvaluator when null) in
// batches of up to kEvaluationBatch midpoints, so that the memory it uses
// does not grow with the trajectory (unless samples are kept). `stop` is
// polled between batches. Fails only when the evaluator does, or with
// Cancelled once `stop` is reached.
absl::StatusOr<TrajectoryEvaluation> EvaluateTrajectory(const RiskModel& model,
                                                        std::span<const TrajectoryPiece> pieces,
                                                        const EvaluationOptions& options = {},
                                                        RiskEvaluator* evaluator = nullptr,
                                                        const StopCondition& stop = {});

// How long a flight of `length_m` lasts at `airspeed_mps` in still air (spec
// section 4: the aircraft flies at constant airspeed along the path's 3-D
// length), s. In wind the time is TrajectoryEvaluation::flight_time_s.
double FlightTimeS(double length_m, double airspeed_mps);

// Expected casualties per flight hour of a flight of `risk` expected
// casualties per flight lasting `flight_time_s`: risk / (flight_time_s /
// 3600), the unit of a target level of safety (SORA: 1e-6 per flight hour).
// 0 when the flight lasts no time (a trajectory of length 0 has risk 0).
double RiskPerFlightHour(double risk, double flight_time_s);

// A pose of the flown path and where it is along it.
struct PathPose {
  Pose pose;
  double arc_length_m = 0.0;  // from the start of the trajectory
  int piece = 0;              // index of the piece it lies on
};

// How many poses SamplePath gives for a path of `length_m` at `step_m`:
// ceil(length_m / step_m) + 1 (1 for a path of length 0), saturating at
// INT64_MAX for a count a double cannot hold (never reached for a bounded
// request: check it before sampling). REQUIRES: step_m > 0, length_m >= 0.
int64_t PathPoseCount(double length_m, double step_m);

// The path of `pieces` sampled at arc lengths 0, step_m, 2 step_m, ... below
// its length L, then at L (its last pose), so consecutive poses are step_m
// apart along the path, the last gap being (0, step_m]. At most `max_poses`
// poses: past max_poses - 1 the rest are left out and the last pose is still
// the end. Empty for no pieces. REQUIRES: step_m > 0, max_poses >= 2.
std::vector<PathPose> SamplePath(std::span<const TrajectoryPiece> pieces, double step_m,
                                 size_t max_poses);

}  // namespace riskplan

#endif  // RISKPLAN_CORE_FLIGHT_TRAJECTORY_H_
