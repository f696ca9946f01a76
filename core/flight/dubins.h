// The Dubins airplane of spec section 5: the shortest 2-D Dubins path of
// radius R between two poses (words LSL, RSR, LSR, RSL, RLR, LRL), with the
// altitude change flown either along it at a constant slope or, when that slope
// would exceed gamma_max, after k full turns of a spiral on the first turning
// circle.
//
// Parameterisation: a manoeuvre is sampled by its 3-D arc length
// s in [0, Length()]. Because the slope is constant over the whole horizontal
// length (spiral included), horizontal arc length is s * HorizontalLength() /
// Length() and z is linear in s.
#ifndef RISKPLAN_CORE_FLIGHT_DUBINS_H_
#define RISKPLAN_CORE_FLIGHT_DUBINS_H_

#include <array>
#include <span>
#include <string_view>

#include "core/base/geometry.h"

namespace riskplan {

enum class DubinsWord { kLSL = 0, kRSR, kLSR, kRSL, kRLR, kLRL };

// "LSL", "RSR", ...
std::string_view DubinsWordName(DubinsWord word);

// A shortest planar Dubins path: start pose (x, y, theta), word, and the lengths
// in metres of its three parts (turn, straight or turn, turn).
struct DubinsPath2D {
  double x = 0.0;
  double y = 0.0;
  double theta = 0.0;
  double radius = 1.0;
  DubinsWord word = DubinsWord::kLSL;
  std::array<double, 3> segment_length_m = {0.0, 0.0, 0.0};

  double Length() const { return segment_length_m[0] + segment_length_m[1] + segment_length_m[2]; }
  // Pose (z = 0) after horizontal arc length s in [0, Length()] (clamped).
  Pose PoseAt(double s) const;
};

// Shortest planar Dubins path from (x0, y0, th0) to (x1, y1, th1) with turning
// radius `radius` > 0. Among words of equal length (within 1e-9 m) the first in
// the order of DubinsWord wins, so results are deterministic.
DubinsPath2D ShortestDubinsPath(double x0, double y0, double th0, double x1, double y1, double th1,
                                double radius);

// Length of a specific word, or +infinity when the word does not exist for
// these poses. `segments`, when given, receives the three lengths in metres
// (all +infinity when the word does not exist). Exposed for tests.
double DubinsWordLength(DubinsWord word, double x0, double y0, double th0, double x1, double y1,
                        double th1, double radius, std::array<double, 3>* segments = nullptr);

// The spiral decision of spec section 5 with its tolerance: a manoeuvre whose
// planar Dubins path has horizontal length L_h climbs |dz| without a spiral
// when
//   |dz| <= L_h * tan(max_climb_rad) + kClimbSlackRelative * max(1 m, |dz|),
// and otherwise flies k = max(1, ceil((|dz| / tan(max_climb_rad) - L_h) /
// (2 pi R))) full turns first. The slack keeps a climb at exactly the limit
// (dz computed by a caller as L_h * tan(max_climb_rad), with its own rounding)
// from spiralling; it lets a climb exceed the limit by at most 1e-9 of itself
// (at least 1 nm). docs/risk-model.md states the same rule.
inline constexpr double kClimbSlackRelative = 1e-9;

// A Dubins-airplane manoeuvre between two poses.
class DubinsAirplanePath {
 public:
  DubinsAirplanePath() = default;
  // REQUIRES: radius > 0, 0 < max_climb_rad < pi/2, finite poses.
  DubinsAirplanePath(const Pose& start, const Pose& goal, double radius, double max_climb_rad);

  const Pose& start() const { return start_; }
  const Pose& goal() const { return goal_; }
  const DubinsPath2D& planar() const { return planar_; }
  // k, a whole number (a double: it may exceed any integer type).
  double spiral_turns() const { return spiral_turns_; }

  // Horizontal length including the spiral: L_h + 2*pi*R*k.
  double HorizontalLength() const { return horizontal_length_m_; }
  // 3-D length sqrt(HorizontalLength()^2 + dz^2).
  double Length() const { return length_m_; }
  // Climb angle atan(dz / HorizontalLength()) (0 for a zero-length path).
  double ClimbAngle() const;

  // Pose after 3-D arc length s in [0, Length()] (clamped); theta is the
  // heading of the horizontal tangent, normalised to [0, 2*pi).
  Pose PoseAt(double s) const;
  // out[n] = PoseAt(s[n]) for every n, bit for bit; faster for many samples:
  // the states where the planar path's segments begin (and their sines and
  // cosines) are computed once instead of once per sample.
  // REQUIRES: out has room for s.size() poses.
  void PosesAt(std::span<const double> s, Pose* out) const;

 private:
  Pose start_;
  Pose goal_;
  DubinsPath2D planar_;
  double radius_ = 1.0;
  double spiral_turns_ = 0.0;
  double horizontal_length_m_ = 0.0;
  double length_m_ = 0.0;
};

}  // namespace riskplan

#endif  // RISKPLAN_CORE_FLIGHT_DUBINS_H_
