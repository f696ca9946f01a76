// Basic geometric types shared by the whole core: poses in the map frame.
//
// Frame (spec "Frames and units"): local ENU, x east, y north, z altitude above
// mean sea level, all in metres. Heading theta is in radians, counter-clockwise
// from +x (east), normalised to [0, 2*pi).
#ifndef RISKPLAN_CORE_BASE_GEOMETRY_H_
#define RISKPLAN_CORE_BASE_GEOMETRY_H_

#include <cmath>
#include <numbers>

namespace riskplan {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kTwoPi = 2.0 * std::numbers::pi;

// Returns `angle` wrapped into [0, 2*pi). Non-finite input is returned unchanged.
inline double NormalizeHeading(double angle) {
  if (!std::isfinite(angle)) return angle;
  double a = std::fmod(angle, kTwoPi);
  if (a < 0.0) a += kTwoPi;
  // fmod can return exactly 2*pi after the correction for tiny negative inputs.
  if (a >= kTwoPi) a = 0.0;
  return a;
}

// floor(offset / cell) as a cell number in [0, n - 1] (n >= 1), clamped as a
// double before the conversion: an offset far off the grid (a request's point
// at 1e20 m, a clearance of 1e168 m) would otherwise convert a double out of
// int's range, which is undefined behaviour. NaN gives 0.
inline int ClampedCell(double offset, double cell, int n) {
  const double c = std::floor(offset / cell);
  if (!(c > 0.0)) return 0;
  return c >= n - 1 ? n - 1 : static_cast<int>(c);
}

// A configuration q = (x, y, z, theta) of the aircraft.
struct Pose {
  double x = 0.0;      // m, east
  double y = 0.0;      // m, north
  double z = 0.0;      // m, above mean sea level
  double theta = 0.0;  // rad, [0, 2*pi), counter-clockwise from east
};

// A 3-D point of a polyline trajectory.
struct Point3 {
  double x = 0.0;
  double y = 0.0;
  double z = 0.0;
};

}  // namespace riskplan

#endif  // RISKPLAN_CORE_BASE_GEOMETRY_H_
