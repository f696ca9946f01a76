// An exact nearest-neighbour structure for OMPL planners on
// DubinsAirplaneSpace, for the OMPL peer benchmark.
//
// OMPL's own structures do not fit this space: GNAT prunes with the triangle
// inequality, which Dubins-airplane length does not satisfy, and
// NearestNeighborsSqrtApprox answers nearest() from sqrt(n) elements only and
// nearestK()/nearestR() by computing the distance to every element (its
// partial sort even recomputes distances inside the comparator). This one
// buckets elements on a horizontal grid and uses that the straight-line 3-D
// distance is a lower bound of the Dubins-airplane length: it computes exact
// distances only for elements whose straight-line distance could still beat
// the current k-th best, so its answers are exactly those of a linear scan
// (NearestNeighborsLinear), at a fraction of the distance calls.
//
// Distances are taken as distFun_(element, query), the direction OMPL's
// linear structures use: for a tree grown from the start, the length of the
// manoeuvre flown from the tree node to the query.
//
// OMPL default-constructs the structure, so its grid is read from
// GridNeighborsLayout(), which must be set before the planner's setup().
#ifndef RISKPLAN_BENCH_OMPL_GRID_NEAREST_NEIGHBORS_H_
#define RISKPLAN_BENCH_OMPL_GRID_NEAREST_NEIGHBORS_H_

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <queue>
#include <utility>
#include <vector>

#include "bench/ompl/risk_state_space.h"
#include "ompl/datastructures/NearestNeighbors.h"
#include "ompl/util/Exception.h"

namespace riskplan::bench {

struct GridLayout {
  double x0 = 0.0;
  double y0 = 0.0;
  double width_m = 1.0;
  double height_m = 1.0;
  double cell_m = 200.0;
};

// The layout every GridNearestNeighbors built afterwards uses.
inline GridLayout& GridNeighborsLayout() {
  static GridLayout layout;
  return layout;
}

// The state of an element: RRT*'s Motion* has a `state` member, BIT*'s
// vertices a `state()` accessor.
template <typename T>
const ompl::base::State* StateOf(const T& item) {
  if constexpr (requires { item->state(); }) {
    return item->state();
  } else {
    return item->state;
  }
}

template <typename T>
class GridNearestNeighbors final : public ompl::NearestNeighbors<T> {
 public:
  GridNearestNeighbors() : layout_(GridNeighborsLayout()) {
    nx_ = std::max(1, static_cast<int>(std::ceil(layout_.width_m / layout_.cell_m)));
    ny_ = std::max(1, static_cast<int>(std::ceil(layout_.height_m / layout_.cell_m)));
    cells_.resize(static_cast<size_t>(nx_) * ny_);
  }

  bool reportsSortedResults() const override { return true; }

  void clear() override {
    for (auto& cell : cells_) cell.clear();
    size_ = 0;
  }

  void add(const T& item) override {
    const Pose p = DubinsAirplaneSpace::ToPose(StateOf(item));
    cells_[CellIndex(Column(p.x), Row(p.y))].push_back(Entry{item, p.x, p.y, p.z});
    ++size_;
  }

  bool remove(const T& item) override {
    const Pose p = DubinsAirplaneSpace::ToPose(StateOf(item));
    std::vector<Entry>& cell = cells_[CellIndex(Column(p.x), Row(p.y))];
    for (size_t n = 0; n < cell.size(); ++n) {
      if (cell[n].item == item) {
        cell[n] = std::move(cell.back());
        cell.pop_back();
        --size_;
        return true;
      }
    }
    return false;
  }

  T nearest(const T& query) const override {
    std::vector<T> out;
    nearestK(query, 1, out);
    if (out.empty()) throw ompl::Exception("GridNearestNeighbors: no elements");
    return out.front();
  }

  void nearestK(const T& query, std::size_t k, std::vector<T>& nbh) const override {
    nbh.clear();
    if (k == 0 || size_ == 0) return;
    const Pose q = DubinsAirplaneSpace::ToPose(StateOf(query));
    const int ci = Column(q.x);
    const int cj = Row(q.y);
    // Max-heap of the k best (distance, element) found so far.
    std::priority_queue<std::pair<double, size_t>> best;
    std::vector<T> found;
    size_t seen = 0;
    for (int ring = 0; seen < size_; ++ring) {
      // Every cell of this ring is at least (ring - 1) cells away.
      const double ring_bound = std::max(0, ring - 1) * layout_.cell_m;
      if (best.size() == k && ring_bound >= best.top().first) break;
      ForRing(ci, cj, ring, [&](const std::vector<Entry>& cell) {
        seen += cell.size();
        for (const Entry& e : cell) {
          if (best.size() == k && Straight(e, q) >= best.top().first) continue;
          const double d = this->distFun_(e.item, query);
          if (best.size() < k) {
            best.push({d, found.size()});
            found.push_back(e.item);
          } else if (d < best.top().first) {
            found[best.top().second] = e.item;
            const size_t slot = best.top().second;
            best.pop();
            best.push({d, slot});
          }
        }
      });
      if (ring > nx_ + ny_) break;
    }
    std::vector<std::pair<double, size_t>> sorted;
    while (!best.empty()) {
      sorted.push_back(best.top());
      best.pop();
    }
    std::sort(sorted.begin(), sorted.end());
    for (const auto& [d, slot] : sorted) nbh.push_back(found[slot]);
  }

  void nearestR(const T& query, double radius, std::vector<T>& nbh) const override {
    nbh.clear();
    const Pose q = DubinsAirplaneSpace::ToPose(StateOf(query));
    const int ci = Column(q.x);
    const int cj = Row(q.y);
    std::vector<std::pair<double, size_t>> within;
    std::vector<T> found;
    size_t seen = 0;
    for (int ring = 0; seen < size_; ++ring) {
      if (std::max(0, ring - 1) * layout_.cell_m > radius) break;
      ForRing(ci, cj, ring, [&](const std::vector<Entry>& cell) {
        seen += cell.size();
        for (const Entry& e : cell) {
          if (Straight(e, q) > radius) continue;
          const double d = this->distFun_(e.item, query);
          if (d <= radius) {
            within.push_back({d, found.size()});
            found.push_back(e.item);
          }
        }
      });
      if (ring > nx_ + ny_) break;
    }
    std::sort(within.begin(), within.end());
    for (const auto& [d, slot] : within) nbh.push_back(found[slot]);
  }

  std::size_t size() const override { return size_; }

  void list(std::vector<T>& data) const override {
    data.clear();
    data.reserve(size_);
    for (const auto& cell : cells_) {
      for (const Entry& e : cell) data.push_back(e.item);
    }
  }

 private:
  struct Entry {
    T item;
    double x, y, z;
  };

  int Column(double x) const {
    return std::clamp(static_cast<int>(std::floor((x - layout_.x0) / layout_.cell_m)), 0, nx_ - 1);
  }
  int Row(double y) const {
    return std::clamp(static_cast<int>(std::floor((y - layout_.y0) / layout_.cell_m)), 0, ny_ - 1);
  }
  size_t CellIndex(int i, int j) const { return static_cast<size_t>(j) * nx_ + i; }
  static double Straight(const Entry& e, const Pose& q) {
    return std::sqrt((e.x - q.x) * (e.x - q.x) + (e.y - q.y) * (e.y - q.y) +
                     (e.z - q.z) * (e.z - q.z));
  }

  // Calls f(cell) for every cell of the grid at Chebyshev distance `ring`
  // from (ci, cj).
  template <typename F>
  void ForRing(int ci, int cj, int ring, F&& f) const {
    for (int j = cj - ring; j <= cj + ring; ++j) {
      if (j < 0 || j >= ny_) continue;
      const bool edge_row = j == cj - ring || j == cj + ring;
      for (int i = ci - ring; i <= ci + ring; i += edge_row || ring == 0 ? 1 : 2 * ring) {
        if (i < 0 || i >= nx_) continue;
        f(cells_[CellIndex(i, j)]);
      }
    }
  }

  GridLayout layout_;
  int nx_ = 1;
  int ny_ = 1;
  std::vector<std::vector<Entry>> cells_;
  size_t size_ = 0;
};

}  // namespace riskplan::bench

#endif  // RISKPLAN_BENCH_OMPL_GRID_NEAREST_NEIGHBORS_H_
