#include "core/planners/obstacle_points.h"

#include <algorithm>
#include <cmath>

#include "core/base/geometry.h"

namespace riskplan {

double SquaredDistanceToSegment(const Point2& p, const Point2& a, const Point2& b) {
  const double dx = b.x - a.x;
  const double dy = b.y - a.y;
  const double len2 = dx * dx + dy * dy;
  double t = 0.0;
  if (len2 > 0.0) t = std::clamp(((p.x - a.x) * dx + (p.y - a.y) * dy) / len2, 0.0, 1.0);
  const double ex = a.x + t * dx - p.x;
  const double ey = a.y + t * dy - p.y;
  return ex * ex + ey * ey;
}

ObstaclePointSet::ObstaclePointSet(std::vector<Point2> points, double bucket_m) {
  if (points.empty()) return;
  double x1 = points[0].x, y1 = points[0].y;
  x0_ = x1;
  y0_ = y1;
  for (const Point2& p : points) {
    x0_ = std::min(x0_, p.x);
    y0_ = std::min(y0_, p.y);
    x1 = std::max(x1, p.x);
    y1 = std::max(y1, p.y);
  }
  bucket_m_ = std::max(bucket_m, 1e-3);
  // Cap the grid: about 4 Mi buckets at most.
  constexpr double kMaxBuckets = 4.0 * 1024 * 1024;
  while (((x1 - x0_) / bucket_m_ + 1) * ((y1 - y0_) / bucket_m_ + 1) > kMaxBuckets) {
    bucket_m_ *= 2.0;
  }
  nx_ = static_cast<int>((x1 - x0_) / bucket_m_) + 1;
  ny_ = static_cast<int>((y1 - y0_) / bucket_m_) + 1;
  std::vector<uint32_t> count(static_cast<size_t>(nx_) * ny_ + 1, 0);
  std::vector<uint32_t> bucket_of(points.size());
  for (size_t k = 0; k < points.size(); ++k) {
    bucket_of[k] = static_cast<uint32_t>(BucketY(points[k].y) * nx_ + BucketX(points[k].x));
    ++count[bucket_of[k] + 1];
  }
  for (size_t b = 1; b < count.size(); ++b) count[b] += count[b - 1];
  bucket_start_ = count;
  points_.resize(points.size());
  // A stable counting sort: the order inside a bucket is the input order.
  for (size_t k = 0; k < points.size(); ++k) points_[count[bucket_of[k]]++] = points[k];
}

int ObstaclePointSet::BucketX(double x) const { return ClampedCell(x - x0_, bucket_m_, nx_); }

int ObstaclePointSet::BucketY(double y) const { return ClampedCell(y - y0_, bucket_m_, ny_); }

bool ObstaclePointSet::SegmentClear(const Point2& a, const Point2& b, double clearance_m) const {
  if (points_.empty()) return true;
  const double c2 = clearance_m * clearance_m;
  const int bx0 = BucketX(std::min(a.x, b.x) - clearance_m);
  const int bx1 = BucketX(std::max(a.x, b.x) + clearance_m);
  const int by0 = BucketY(std::min(a.y, b.y) - clearance_m);
  const int by1 = BucketY(std::max(a.y, b.y) + clearance_m);
  for (int by = by0; by <= by1; ++by) {
    // Buckets of one row are contiguous in the CSR layout.
    const uint32_t begin = bucket_start_[static_cast<size_t>(by) * nx_ + bx0];
    const uint32_t end = bucket_start_[static_cast<size_t>(by) * nx_ + bx1 + 1];
    for (uint32_t k = begin; k < end; ++k) {
      if (SquaredDistanceToSegment(points_[k], a, b) <= c2) return false;
    }
  }
  return true;
}

bool ObstaclePointSet::SegmentClearBruteForce(const Point2& a, const Point2& b,
                                              double clearance_m) const {
  const double c2 = clearance_m * clearance_m;
  for (const Point2& p : points_) {
    if (SquaredDistanceToSegment(p, a, b) <= c2) return false;
  }
  return true;
}

int64_t ObstaclePointSet::PointWithin(const Point2& p, double clearance_m) const {
  if (points_.empty()) return -1;
  const double c2 = clearance_m * clearance_m;
  for (int by = BucketY(p.y - clearance_m); by <= BucketY(p.y + clearance_m); ++by) {
    const uint32_t begin =
        bucket_start_[static_cast<size_t>(by) * nx_ + BucketX(p.x - clearance_m)];
    const uint32_t end =
        bucket_start_[static_cast<size_t>(by) * nx_ + BucketX(p.x + clearance_m) + 1];
    for (uint32_t k = begin; k < end; ++k) {
      const double dx = points_[k].x - p.x;
      const double dy = points_[k].y - p.y;
      if (dx * dx + dy * dy <= c2) return k;
    }
  }
  return -1;
}

std::vector<Point2> MapObstaclePoints(const RiskMap& map, const std::vector<uint8_t>& flyable) {
  std::vector<Point2> out;
  const int nx = map.nx();
  const int ny = map.ny();
  auto free_at = [&](int i, int j) {
    return i >= 0 && j >= 0 && i < nx && j < ny && flyable[map.Index(i, j)] != 0;
  };
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      if (flyable[map.Index(i, j)] != 0) continue;
      if (free_at(i + 1, j) || free_at(i - 1, j) || free_at(i, j + 1) || free_at(i, j - 1)) {
        out.push_back({map.x0() + (i + 0.5) * map.res(), map.y0() + (j + 0.5) * map.res()});
      }
    }
  }
  return out;
}

}  // namespace riskplan
