// Point obstacles and the clearance test of seed 004's RRT: a segment is
// clear when every obstacle point lies farther than the clearance radius xi
// from it.
//
// Seed 004 computes the distance from every obstacle point to the segment in
// parallel hardware. On a CPU riskplan buckets the points on a square grid and
// measures only those in the buckets that the segment's bounding box, grown by
// xi, overlaps: every point within xi of the segment lies in that box, so the
// answer is exactly the brute-force one (tested), in time that depends on the
// points near the segment rather than on all of them.
#ifndef RISKPLAN_CORE_PLANNERS_OBSTACLE_POINTS_H_
#define RISKPLAN_CORE_PLANNERS_OBSTACLE_POINTS_H_

#include <cstdint>
#include <vector>

#include "core/map/risk_map.h"
#include "core/planners/planner.h"

namespace riskplan {

// Squared horizontal distance from p to the segment ab.
double SquaredDistanceToSegment(const Point2& p, const Point2& a, const Point2& b);

// An immutable set of point obstacles with a bucket index. Thread-safe.
class ObstaclePointSet {
 public:
  ObstaclePointSet() = default;
  // `bucket_m` > 0 is the bucket side; a value near the clearance radius
  // used in queries is a good choice. The grid is capped at about 4 Mi
  // buckets (larger buckets for very spread-out points).
  ObstaclePointSet(std::vector<Point2> points, double bucket_m);

  size_t size() const { return points_.size(); }
  const std::vector<Point2>& points() const { return points_; }

  // True when every point lies strictly farther than `clearance_m` from the
  // segment ab (horizontal distance).
  bool SegmentClear(const Point2& a, const Point2& b, double clearance_m) const;
  // The same answer, by measuring every point (for tests and benchmarks).
  bool SegmentClearBruteForce(const Point2& a, const Point2& b, double clearance_m) const;
  // Index of a point within `clearance_m` (inclusive) of p, or -1.
  int64_t PointWithin(const Point2& p, double clearance_m) const;

 private:
  int BucketX(double x) const;
  int BucketY(double y) const;

  std::vector<Point2> points_;          // sorted by bucket
  std::vector<uint32_t> bucket_start_;  // CSR: points of bucket b are [start[b], start[b+1])
  double x0_ = 0.0;
  double y0_ = 0.0;
  double bucket_m_ = 1.0;
  int nx_ = 0;
  int ny_ = 0;
};

// Seed 004's obstacle points taken from a map: the centres of the cells that
// `flyable` (per cell, index j * nx + i, as FlyableCells gives) marks as not
// flyable and that have a flyable 4-neighbour. The inner cells of a blocked
// region are left out: a segment between two flyable points cannot reach them
// without passing within res / sqrt(2) of a border cell's centre, so with a
// clearance of at least that the border cells alone block the region.
std::vector<Point2> MapObstaclePoints(const RiskMap& map, const std::vector<uint8_t>& flyable);

}  // namespace riskplan

#endif  // RISKPLAN_CORE_PLANNERS_OBSTACLE_POINTS_H_
