// TrajectoryPiece: one piece of a trajectory, a straight segment or a
// Dubins-airplane manoeuvre, parameterised by 3-D arc length.
#ifndef RISKPLAN_CORE_FLIGHT_TRAJECTORY_PIECE_H_
#define RISKPLAN_CORE_FLIGHT_TRAJECTORY_PIECE_H_

#include <span>

#include "core/base/check.h"
#include "core/base/geometry.h"
#include "core/flight/dubins.h"

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
  // out[n] = PoseAt(s[n]) for every n, bit for bit (a manoeuvre's turns
  // computed once for all of them). REQUIRES: out has room for s.size().
  void PosesAt(std::span<const double> s, Pose* out) const;
  Pose Start() const { return PoseAt(0.0); }
  Pose End() const { return PoseAt(length_m_); }
  // REQUIRES: !is_segment().
  const DubinsAirplanePath& manoeuvre() const {
    RISKPLAN_DCHECK(!is_segment_);
    return manoeuvre_;
  }

 private:
  bool is_segment_ = true;
  Point3 a_;
  Point3 b_;
  double heading_ = 0.0;
  DubinsAirplanePath manoeuvre_;
  double length_m_ = 0.0;
};

}  // namespace riskplan

#endif  // RISKPLAN_CORE_FLIGHT_TRAJECTORY_PIECE_H_
