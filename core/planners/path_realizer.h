// From a planar path to a flyable trajectory.
//
// RRT grows straight edges, the harmonic descent moves from cell to cell and a
// GA chromosome is a list of points; riskplan flies none of these as they are.
// Every planner streams waypoints joined by Dubins-airplane manoeuvres (spec
// section 5) that must be admissible (spec section 6). This file holds the
// exact check of such a trajectory (TrajectoryChecker) and the conversion of a
// planar path into one (PathRealizer). docs/planners.md, "From a path to a
// trajectory", explains the choices.
#ifndef RISKPLAN_CORE_PLANNERS_PATH_REALIZER_H_
#define RISKPLAN_CORE_PLANNERS_PATH_REALIZER_H_

#include <optional>
#include <span>
#include <vector>

#include "core/base/geometry.h"
#include "core/flight/trajectory.h"
#include "core/planners/obstacle_points.h"
#include "core/planners/planner.h"
#include "core/risk/risk_model.h"

namespace riskplan {

// An axis-aligned rectangle [x0, x1] x [y0, y1] in map metres that the
// trajectory must not touch (an active dynamic obstacle).
struct ClosedArea {
  double x0_m = 0.0;
  double y0_m = 0.0;
  double x1_m = 0.0;
  double y1_m = 0.0;
};

// True when segment ab touches the closed rectangle.
bool SegmentTouchesArea(const Point2& a, const Point2& b, const ClosedArea& area);

// The exact check of a trajectory: the samples of spec section 6 (every
// piece's start, its K midpoints and its end, exactly those EvaluateTrajectory
// checks) and, for the request's obstacles, the chords between consecutive
// samples. A chord must keep every obstacle point farther than clearance_m +
// a margin that covers the distance between a chord and the arc it stands for
// (at most ds^2 / (8 R) for samples ds apart on a turn of radius R), and must
// not touch a closed area. Thread-compatible; `points` must outlive it.
class TrajectoryChecker {
 public:
  TrajectoryChecker(const RiskModel& model, const ObstaclePointSet* points, double clearance_m,
                    std::vector<ClosedArea> closed_areas = {});

  const RiskModel& model() const { return model_; }
  void set_closed_areas(std::vector<ClosedArea> areas) { closed_areas_ = std::move(areas); }

  // Number of failing samples and chords of `piece`; stops at the first when
  // `first_only`.
  int Violations(const TrajectoryPiece& piece, bool first_only) const;
  // The same over the manoeuvres joining consecutive waypoints.
  int Violations(std::span<const Pose> waypoints, bool first_only) const;

 private:
  bool SampleFails(const Pose& q) const;
  bool ChordFails(const Pose& a, const Pose& b, double margin_m) const;

  const RiskModel& model_;
  const ObstaclePointSet* points_;
  double clearance_m_;
  std::vector<ClosedArea> closed_areas_;
};

struct RealizerOptions {
  // Preferred altitude, m AMSL; 0: the middle of each cell's band.
  double flight_altitude_m = 0.0;
  // The altitude profile keeps this far inside each cell's band where the
  // band is wide enough, m.
  double band_margin_m = 3.0;
  // The profile climbs at most this fraction of tan(max_climb), so that the
  // straight chords between waypoints stay within the climb limit.
  double slope_fraction = 0.7;
  // Largest distance from a manoeuvre's chord to the path points it replaces,
  // m: the trajectory follows the planner's path within about this (plus the
  // turns of the manoeuvres). 0: no limit, the straightest trajectory that
  // passes the check.
  double max_deviation_m = 0.0;
  // Largest number of waypoints of a result.
  size_t max_waypoints = 2000;
};

// Turns a planar path into waypoints whose Dubins-airplane trajectory passes
// the TrajectoryChecker. Steps:
// 1. the path is resampled at least every map cell;
// 2. an altitude profile along it: the start's and the goal's altitudes at
//    the ends, inside every sample's band (RealizerOptions), climbing no
//    faster than the slope limit, as close as allowed to the preferred
//    altitude (forward and backward interval propagation, then a greedy pass);
// 3. waypoints top-down, as Douglas-Peucker: first start and goal alone;
//    every manoeuvre whose chord lies farther than max_deviation_m from a path
//    point between, or that fails the exact check, is split at the resampled
//    point farthest from its chord (at the middle of its arc when the path
//    between is nearly straight), until every manoeuvre passes. An interior
//    waypoint's heading bisects its two chords; start and goal keep theirs.
// Deterministic. Thread-compatible.
class PathRealizer {
 public:
  PathRealizer(const TrajectoryChecker& checker, RealizerOptions options);

  // REQUIRES: path.size() >= 2; path.front() is the start's (x, y) and
  // path.back() the goal's. Returns the waypoints (start ... goal, the start
  // and goal poses exactly), or nullopt when no trajectory along the path
  // passes: a sample in a cell with no band, no altitude profile within the
  // slope limit, or a manoeuvre that still fails where the path has no point
  // left to split at.
  std::optional<std::vector<Pose>> Realize(const Pose& start, const Pose& goal,
                                           std::span<const Point2> path) const;

 private:
  bool Profile(const Pose& start, const Pose& goal, const std::vector<Point2>& points,
               const std::vector<double>& arc, double margin_m, double slope,
               std::vector<double>* z) const;

  const TrajectoryChecker& checker_;
  const RiskModel& model_;
  RealizerOptions options_;
};

// Heading of an interior waypoint: the bisector of the directions a -> b and
// b -> c (the other one when a chord has length 0; 0 when both have).
double BisectorHeading(const Point2& a, const Point2& b, const Point2& c);

}  // namespace riskplan

#endif  // RISKPLAN_CORE_PLANNERS_PATH_REALIZER_H_
