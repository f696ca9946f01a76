// SpatialGrid: an incremental 2-D bucket grid over node positions, for the
// planners' neighbour queries.
//
// RRT* samples spread roughly uniformly over a map and arrive one at a time; a
// grid of square buckets handles that with O(1) insertion and queries that
// visit only the buckets a search circle touches, and gives deterministic
// results (ties broken by id). Not thread-safe.
#ifndef RISKPLAN_CORE_PLANNERS_SPATIAL_GRID_H_
#define RISKPLAN_CORE_PLANNERS_SPATIAL_GRID_H_

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/base/geometry.h"

namespace riskplan {

class SpatialGrid {
 public:
  // Covers [x0, x0 + width) x [y0, y0 + height); points outside are clamped
  // into the border buckets (queries stay exact).
  SpatialGrid(double x0, double y0, double width, double height, double bucket_m)
      : x0_(x0), y0_(y0), bucket_(bucket_m) {
    nx_ = std::max(1, static_cast<int>(std::ceil(width / bucket_m)));
    ny_ = std::max(1, static_cast<int>(std::ceil(height / bucket_m)));
    buckets_.resize(static_cast<size_t>(nx_) * ny_);
  }

  void Insert(int32_t id, double x, double y) {
    buckets_[BucketIndex(BucketX(x), BucketY(y))].push_back({id, x, y});
    ++size_;
  }
  size_t size() const { return size_; }

  // Appends (squared distance, id) of every point within `radius` of (x, y).
  void WithinRadius(double x, double y, double radius,
                    std::vector<std::pair<double, int32_t>>* out) const {
    const double r2 = radius * radius;
    const int bx0 = BucketX(x - radius), bx1 = BucketX(x + radius);
    const int by0 = BucketY(y - radius), by1 = BucketY(y + radius);
    for (int by = by0; by <= by1; ++by) {
      for (int bx = bx0; bx <= bx1; ++bx) {
        for (const Entry& e : buckets_[BucketIndex(bx, by)]) {
          const double d2 = (e.x - x) * (e.x - x) + (e.y - y) * (e.y - y);
          if (d2 <= r2) out->push_back({d2, e.id});
        }
      }
    }
  }

  // The k nearest points to (x, y) as (squared distance, id), nearest first,
  // ties by id.
  std::vector<std::pair<double, int32_t>> Nearest(double x, double y, size_t k) const {
    std::vector<std::pair<double, int32_t>> found;
    if (k == 0 || size_ == 0) return found;
    const int cx = BucketX(x);
    const int cy = BucketY(y);
    const int max_ring = std::max(nx_, ny_);
    for (int ring = 0; ring <= max_ring; ++ring) {
      for (int by = cy - ring; by <= cy + ring; ++by) {
        if (by < 0 || by >= ny_) continue;
        const bool edge_row = (by == cy - ring || by == cy + ring);
        for (int bx = cx - ring; bx <= cx + ring; bx += (edge_row ? 1 : 2 * ring)) {
          if (bx >= 0 && bx < nx_) {
            for (const Entry& e : buckets_[BucketIndex(bx, by)]) {
              found.push_back({(e.x - x) * (e.x - x) + (e.y - y) * (e.y - y), e.id});
            }
          }
          if (ring == 0) break;
        }
      }
      if (found.size() >= k) {
        // Every point not yet seen is at least `ring` buckets away.
        std::sort(found.begin(), found.end());
        const double reach = ring * bucket_;
        if (found[k - 1].first <= reach * reach) break;
      }
    }
    std::sort(found.begin(), found.end());
    if (found.size() > k) found.resize(k);
    return found;
  }

 private:
  struct Entry {
    int32_t id;
    double x;
    double y;
  };
  int BucketX(double x) const {
    return ClampedCell(x - x0_, bucket_, nx_);
  }
  int BucketY(double y) const {
    return ClampedCell(y - y0_, bucket_, ny_);
  }
  size_t BucketIndex(int bx, int by) const { return static_cast<size_t>(by) * nx_ + bx; }

  double x0_;
  double y0_;
  double bucket_;
  int nx_ = 1;
  int ny_ = 1;
  size_t size_ = 0;
  std::vector<std::vector<Entry>> buckets_;
};

}  // namespace riskplan

#endif  // RISKPLAN_CORE_PLANNERS_SPATIAL_GRID_H_
