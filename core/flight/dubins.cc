#include "core/flight/dubins.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string_view>

#include "core/base/check.h"
#include "core/base/geometry.h"

namespace riskplan {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Words whose lengths differ by no more than this are ties (header contract).
constexpr double kTieToleranceM = 1e-9;

// A turn computed as 2*pi - epsilon is almost always rounding noise of a zero
// turn (e.g. a tangent direction that equals the start heading up to one ulp);
// flying it would add a spurious full circle. Rounding noise of the angles below
// is ~1e-14 rad even for poses thousands of turning radii apart, so 1e-10 rad
// leaves a wide margin while moving an endpoint by at most R * 1e-10.
constexpr double kFullTurnSnapRad = 1e-10;

// Squared-distance tests (circles tangent for LSR/RSL, three circles in a row
// for RLR/LRL) are evaluated in units of R^2; this absorbs their rounding so
// that exactly tangent configurations are not rejected.
constexpr double kSquaredDistanceSlack = 1e-12;

// Centres of two turning circles closer than this (in units of R, scaled by the
// distance of the poses to follow the rounding noise) are treated as
// coincident: the direction between them is then noise, so it is not used.
constexpr double kCoincidentCentres = 1e-12;

// A heading within this of 2*pi is reported as 0, so that an endpoint with a
// goal heading of 0 does not come out as 2*pi - 1e-15.
constexpr double kHeadingSnapRad = 1e-12;

enum class Segment { kLeft, kStraight, kRight };

constexpr std::array<std::array<Segment, 3>, 6> kWordSegments = {{
    {Segment::kLeft, Segment::kStraight, Segment::kLeft},    // LSL
    {Segment::kRight, Segment::kStraight, Segment::kRight},  // RSR
    {Segment::kLeft, Segment::kStraight, Segment::kRight},   // LSR
    {Segment::kRight, Segment::kStraight, Segment::kLeft},   // RSL
    {Segment::kRight, Segment::kLeft, Segment::kRight},      // RLR
    {Segment::kLeft, Segment::kRight, Segment::kLeft},       // LRL
}};

constexpr std::array<DubinsWord, 6> kAllWords = {DubinsWord::kLSL, DubinsWord::kRSR,
                                                 DubinsWord::kLSR, DubinsWord::kRSL,
                                                 DubinsWord::kRLR, DubinsWord::kLRL};

const std::array<Segment, 3>& SegmentsOf(DubinsWord word) {
  return kWordSegments[static_cast<int>(word)];
}

// A turn angle in [0, 2*pi) with near-full turns snapped to 0 (see above).
double TurnAngle(double angle) {
  const double a = NormalizeHeading(angle);
  return a > kTwoPi - kFullTurnSnapRad ? 0.0 : a;
}

double OutputHeading(double angle) {
  const double a = NormalizeHeading(angle);
  return a > kTwoPi - kHeadingSnapRad ? 0.0 : a;
}

// The problem in the normalised frame of Shkel & Lumelsky: start at the
// origin, goal at (d, 0), lengths in units of R, headings measured from the
// start-to-goal direction.
struct NormalisedProblem {
  double d = 0.0;
  double alpha = 0.0;
  double beta = 0.0;
  double sa = 0.0;
  double ca = 1.0;
  double sb = 0.0;
  double cb = 1.0;
};

NormalisedProblem Normalise(double x0, double y0, double th0, double x1, double y1, double th1,
                            double radius) {
  const double dx = x1 - x0;
  const double dy = y1 - y0;
  // atan2(0, 0) = 0 gives a valid frame for coincident positions.
  const double phi = std::atan2(dy, dx);
  NormalisedProblem n;
  n.d = std::hypot(dx, dy) / radius;
  n.alpha = NormalizeHeading(th0 - phi);
  n.beta = NormalizeHeading(th1 - phi);
  n.sa = std::sin(n.alpha);
  n.ca = std::cos(n.alpha);
  n.sb = std::sin(n.beta);
  n.cb = std::cos(n.beta);
  return n;
}

// Segment lengths (units of R) of `word`, or false when it does not exist.
// The formulas are those of Shkel & Lumelsky / LaValle, written in terms of the
// vector v between the two turning circles' centres: computing |v| from its
// components instead of from the expanded law of cosines keeps the straight
// length exact (no sqrt of cancellation noise) when the centres nearly meet.
// Centres in the normalised frame: start left (-sa, ca), start right (sa, -ca),
// goal left (d - sb, cb), goal right (d + sb, -cb).
bool NormalisedSegments(DubinsWord word, const NormalisedProblem& n, std::array<double, 3>* out) {
  const double coincident = kCoincidentCentres * (1.0 + n.d);
  double t = 0.0;
  double p = 0.0;
  double q = 0.0;
  switch (word) {
    case DubinsWord::kLSL:
    case DubinsWord::kRSR: {
      const bool left = word == DubinsWord::kLSL;
      const double vx = left ? n.d - n.sb + n.sa : n.d + n.sb - n.sa;
      const double vy = left ? n.cb - n.ca : n.ca - n.cb;
      p = std::hypot(vx, vy);
      const double turn = left ? n.beta - n.alpha : n.alpha - n.beta;
      if (p <= coincident) {
        // Both poses lie on one circle: a single turn, no straight.
        p = 0.0;
        t = TurnAngle(turn);
        q = 0.0;
      } else {
        const double psi = std::atan2(vy, vx);  // heading of the straight
        t = TurnAngle(left ? psi - n.alpha : n.alpha - psi);
        q = TurnAngle(left ? n.beta - psi : psi - n.beta);
      }
      break;
    }
    case DubinsWord::kLSR:
    case DubinsWord::kRSL: {
      const bool lsr = word == DubinsWord::kLSR;
      const double vx = lsr ? n.d + n.sb + n.sa : n.d - n.sb - n.sa;
      const double vy = lsr ? -n.cb - n.ca : n.cb + n.ca;
      // The inner tangent exists only for circles at least 2R apart.
      const double p_sq = vx * vx + vy * vy - 4.0;
      if (p_sq < -kSquaredDistanceSlack) return false;
      p = std::sqrt(std::max(0.0, p_sq));
      const double tilt = std::atan2(2.0, p);
      const double centre_dir = std::atan2(vy, vx);
      const double psi = lsr ? centre_dir + tilt : centre_dir - tilt;
      t = TurnAngle(lsr ? psi - n.alpha : n.alpha - psi);
      q = TurnAngle(lsr ? psi - n.beta : n.beta - psi);
      break;
    }
    case DubinsWord::kRLR:
    case DubinsWord::kLRL: {
      const bool rlr = word == DubinsWord::kRLR;
      const double vx = rlr ? n.d + n.sb - n.sa : n.d - n.sb + n.sa;
      const double vy = rlr ? n.ca - n.cb : n.cb - n.ca;
      // The middle circle touches both outer ones only if they are <= 4R apart.
      const double dist_sq = vx * vx + vy * vy;
      if (dist_sq > 16.0 + kSquaredDistanceSlack) return false;
      // Apex angle of the isosceles triangle of centres (sides 2, 2, |v|):
      // sin(g/2) = |v|/4. The atan2 form stays accurate at both |v| -> 0 and
      // |v| -> 4, where acos(1 - |v|^2/8) loses digits.
      const double apex =
          2.0 * std::atan2(std::sqrt(dist_sq), std::sqrt(std::max(0.0, 16.0 - dist_sq)));
      // The long way round the middle circle; the short one is never optimal.
      const double middle = kTwoPi - apex;
      const double centre_dir = std::atan2(vy, vx);
      if (rlr) {
        t = TurnAngle(n.alpha - centre_dir + 0.5 * middle);
        q = TurnAngle(n.alpha - n.beta - t + middle);
      } else {
        t = TurnAngle(centre_dir - n.alpha + 0.5 * middle);
        q = TurnAngle(n.beta - n.alpha - t + middle);
      }
      // Coincident outer centres give a full middle loop, which goes nowhere.
      p = TurnAngle(middle);
      break;
    }
  }
  *out = {t, p, q};
  return true;
}

// Planar state of the aircraft with the sine and cosine of its heading kept
// alongside, so each segment costs one sincos.
struct PlanarState {
  double x;
  double y;
  double theta;
  double sin_theta;
  double cos_theta;
};

PlanarState MakeState(double x, double y, double theta) {
  return PlanarState{x, y, theta, std::sin(theta), std::cos(theta)};
}

void Advance(Segment segment, double length, double radius, PlanarState* st) {
  if (length <= 0.0) return;
  if (segment == Segment::kStraight) {
    st->x += length * st->cos_theta;
    st->y += length * st->sin_theta;
    return;
  }
  const double sign = segment == Segment::kLeft ? 1.0 : -1.0;
  const double theta = st->theta + sign * (length / radius);
  const double s = std::sin(theta);
  const double c = std::cos(theta);
  // Position relative to the circle centre is sign * R * (sin, -cos)(theta).
  st->x += sign * radius * (s - st->sin_theta);
  st->y += sign * radius * (st->cos_theta - c);
  st->theta = theta;
  st->sin_theta = s;
  st->cos_theta = c;
}

}  // namespace

std::string_view DubinsWordName(DubinsWord word) {
  switch (word) {
    case DubinsWord::kLSL:
      return "LSL";
    case DubinsWord::kRSR:
      return "RSR";
    case DubinsWord::kLSR:
      return "LSR";
    case DubinsWord::kRSL:
      return "RSL";
    case DubinsWord::kRLR:
      return "RLR";
    case DubinsWord::kLRL:
      return "LRL";
  }
  return "?";
}

Pose DubinsPath2D::PoseAt(double s) const {
  // std::clamp would pass NaN through; treat it as the start.
  double remaining = s > 0.0 ? std::min(s, Length()) : 0.0;
  PlanarState st = MakeState(x, y, theta);
  const std::array<Segment, 3>& segments = SegmentsOf(word);
  for (int i = 0; i < 3 && remaining > 0.0; ++i) {
    const double l = std::min(remaining, segment_length_m[i]);
    Advance(segments[i], l, radius, &st);
    remaining -= l;
  }
  return Pose{st.x, st.y, 0.0, OutputHeading(st.theta)};
}

double DubinsWordLength(DubinsWord word, double x0, double y0, double th0, double x1, double y1,
                        double th1, double radius, std::array<double, 3>* segments) {
  const NormalisedProblem n = Normalise(x0, y0, th0, x1, y1, th1, radius);
  std::array<double, 3> normalised;
  if (!NormalisedSegments(word, n, &normalised)) {
    if (segments != nullptr) *segments = {kInf, kInf, kInf};
    return kInf;
  }
  const std::array<double, 3> metres = {radius * normalised[0], radius * normalised[1],
                                        radius * normalised[2]};
  if (segments != nullptr) *segments = metres;
  return metres[0] + metres[1] + metres[2];
}

DubinsPath2D ShortestDubinsPath(double x0, double y0, double th0, double x1, double y1, double th1,
                                double radius) {
  const NormalisedProblem n = Normalise(x0, y0, th0, x1, y1, th1, radius);
  std::array<std::array<double, 3>, 6> segments;
  std::array<double, 6> lengths;
  double shortest = kInf;
  for (int i = 0; i < 6; ++i) {
    std::array<double, 3>& seg = segments[i];
    if (NormalisedSegments(kAllWords[i], n, &seg)) {
      seg = {radius * seg[0], radius * seg[1], radius * seg[2]};
      lengths[i] = seg[0] + seg[1] + seg[2];
    } else {
      lengths[i] = kInf;
    }
    shortest = std::min(shortest, lengths[i]);
  }
  // First word within the tolerance of the minimum, rather than a running
  // "strictly shorter" comparison, so that the choice does not depend on how
  // near-ties chain up.
  int chosen = 0;
  while (chosen < 5 && !(lengths[chosen] <= shortest + kTieToleranceM)) ++chosen;

  DubinsPath2D path;
  path.x = x0;
  path.y = y0;
  path.theta = NormalizeHeading(th0);
  path.radius = radius;
  path.word = kAllWords[chosen];
  path.segment_length_m = segments[chosen];
  return path;
}

DubinsAirplanePath::DubinsAirplanePath(const Pose& start, const Pose& goal, double radius,
                                       double max_climb_rad)
    : start_(start), goal_(goal), radius_(radius) {
  RISKPLAN_DCHECK(radius > 0.0 && max_climb_rad > 0.0 && max_climb_rad < kPi / 2);
  RISKPLAN_DCHECK(std::isfinite(start.x) && std::isfinite(start.y) && std::isfinite(start.z) &&
                  std::isfinite(start.theta) && std::isfinite(goal.x) && std::isfinite(goal.y) &&
                  std::isfinite(goal.z) && std::isfinite(goal.theta));
  planar_ = ShortestDubinsPath(start.x, start.y, start.theta, goal.x, goal.y, goal.theta, radius);
  const double planar_length = planar_.Length();
  const double dz = goal.z - start.z;
  const double abs_dz = std::abs(dz);
  const double tan_gamma = std::tan(max_climb_rad);
  // kClimbSlackRelative (dubins.h) keeps a climb at exactly gamma_max from
  // spiralling.
  const double slack = kClimbSlackRelative * std::max(1.0, abs_dz);
  if (abs_dz > planar_length * tan_gamma + slack) {
    // Counted in double: a steep climb over a small radius can ask for more
    // turns than an int holds (converting those would be undefined), and the
    // length that results is then too long for any sample bound to accept.
    const double turns = (abs_dz / tan_gamma - planar_length) / (kTwoPi * radius);
    spiral_turns_ = std::max(1.0, std::ceil(turns));
  }
  horizontal_length_m_ = planar_length + kTwoPi * radius * spiral_turns_;
  length_m_ = std::hypot(horizontal_length_m_, dz);
}

double DubinsAirplanePath::ClimbAngle() const {
  if (!(length_m_ > 0.0)) return 0.0;
  return std::atan2(goal_.z - start_.z, horizontal_length_m_);
}

Pose DubinsAirplanePath::PoseAt(double s) const {
  if (!(length_m_ > 0.0)) {
    return Pose{start_.x, start_.y, start_.z, OutputHeading(start_.theta)};
  }
  const double fraction = s > 0.0 ? std::min(s / length_m_, 1.0) : 0.0;
  const double z = start_.z + (goal_.z - start_.z) * fraction;
  const double horizontal = fraction * horizontal_length_m_;
  const double spiral_length = kTwoPi * radius_ * spiral_turns_;
  Pose pose;
  if (horizontal < spiral_length) {
    // Circling the first turning circle of the word; after k full turns this
    // is back at the start pose, where the planar path takes over.
    PlanarState st = MakeState(start_.x, start_.y, start_.theta);
    Advance(SegmentsOf(planar_.word)[0], horizontal, radius_, &st);
    pose = Pose{st.x, st.y, 0.0, OutputHeading(st.theta)};
  } else {
    pose = planar_.PoseAt(horizontal - spiral_length);
  }
  pose.z = z;
  return pose;
}

void DubinsAirplanePath::PosesAt(std::span<const double> arcs, Pose* out) const {
  if (!(length_m_ > 0.0)) {
    for (size_t n = 0; n < arcs.size(); ++n) out[n] = PoseAt(arcs[n]);
    return;
  }
  // PoseAt's arithmetic, operation for operation; only the states it reaches
  // at the start of the spiral and of each planar segment (which do not depend
  // on s) are computed once: at[i] is where segment i begins.
  const double spiral_length = kTwoPi * radius_ * spiral_turns_;
  const PlanarState spiral_start = MakeState(start_.x, start_.y, start_.theta);
  const DubinsPath2D& p = planar_;
  const std::array<Segment, 3>& segments = SegmentsOf(p.word);
  std::array<PlanarState, 3> at;
  at[0] = MakeState(p.x, p.y, p.theta);
  at[1] = at[0];
  Advance(segments[0], p.segment_length_m[0], p.radius, &at[1]);
  at[2] = at[1];
  Advance(segments[1], p.segment_length_m[1], p.radius, &at[2]);
  const double planar_length = p.Length();
  for (size_t n = 0; n < arcs.size(); ++n) {
    const double s = arcs[n];
    const double fraction = s > 0.0 ? std::min(s / length_m_, 1.0) : 0.0;
    const double z = start_.z + (goal_.z - start_.z) * fraction;
    const double horizontal = fraction * horizontal_length_m_;
    Pose pose;
    if (horizontal < spiral_length) {
      PlanarState st = spiral_start;
      Advance(segments[0], horizontal, radius_, &st);
      pose = Pose{st.x, st.y, 0.0, OutputHeading(st.theta)};
    } else {
      // DubinsPath2D::PoseAt(horizontal - spiral_length).
      const double planar_s = horizontal - spiral_length;
      double remaining = planar_s > 0.0 ? std::min(planar_s, planar_length) : 0.0;
      PlanarState st = at[0];
      for (int i = 0; i < 3 && remaining > 0.0; ++i) {
        const double l = std::min(remaining, p.segment_length_m[i]);
        if (i < 2 && l == p.segment_length_m[i]) {
          st = at[i + 1];  // the whole segment from at[i]: Advance gives at[i + 1]
        } else {
          Advance(segments[i], l, p.radius, &st);
        }
        remaining -= l;
      }
      pose = Pose{st.x, st.y, 0.0, OutputHeading(st.theta)};
    }
    pose.z = z;
    out[n] = pose;
  }
}

}  // namespace riskplan
