#include "core/flight/trajectory_piece.h"

#include <algorithm>
#include <cmath>

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

void TrajectoryPiece::PosesAt(std::span<const double> s, Pose* out) const {
  if (!is_segment_) return manoeuvre_.PosesAt(s, out);
  for (size_t n = 0; n < s.size(); ++n) out[n] = PoseAt(s[n]);
}

}  // namespace riskplan
