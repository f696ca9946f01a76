// The harmonic potential of seed 002 (Girau and Boumaza, after Connolly et
// al.): Laplace's equation on a grid, obstacles held at potential 1 and the
// goal at 0, solved by iterative relaxation; a descent from any free cell
// along decreasing potential reaches the goal, because a harmonic function has
// no local minimum inside the free space.
//
// Precision. Seed 002 notes that large grids need more than 22, and on very
// large grids more than 64, fixed-point bits: far from the goal, and along
// corridors, the potential differs from 1 by amounts that decay exponentially,
// and once neighbouring cells round to the same value the descent has nothing
// to follow. riskplan stores the complement v = 1 - u ("the probability that a
// random walk from this cell reaches the goal before an obstacle": 0 on
// obstacles, 1 at the goal) in IEEE double. Floating point keeps 53
// significant bits at every magnitude down to 1e-308, so the tiny values that
// a fixed-point u loses entirely keep their full relative precision: on a
// 1600 x 1600 grid, or along a corridor hundreds of cells long, neighbouring
// values still differ in their leading bits (tested with a corridor where
// 1 - v rounds to exactly 1 everywhere near the start). Descending u is
// ascending v.
//
// Relaxation. Seed 002's nodes update synchronously (Jacobi). riskplan uses
// successive over-relaxation in red-black order: each half-sweep updates every
// cell of one colour from its four neighbours at once, like the seed's grid of
// nodes, and with the over-relaxation factor omega = 2 / (1 + sqrt(1 - rho^2)),
// rho = (cos(pi / nx) + cos(pi / ny)) / 2, it needs O(n) sweeps instead of
// Jacobi's O(n^2) on an n x n grid. Deterministic: the order is fixed.
// Over-relaxation has a cost where values decay steeply (narrow corridors):
// it carries the rounding of the larger values upstream into the tiny ones
// downstream faster than they decay, so that their relative changes stall
// above a fine tolerance; Gauss-Seidel (omega = 1) does not (tested). The
// HARMONIC planner therefore ends with omega = 1 when SOR has not converged
// after 2 (nx + ny) sweeps.
//
// Convergence, as seed 002's per-node "Cvg" test: a sweep in which no free
// cell's value changed by more than tolerance x |its value| (relative, so
// that tiny values converge as strictly as large ones).
#ifndef RISKPLAN_CORE_PLANNERS_HARMONIC_POTENTIAL_H_
#define RISKPLAN_CORE_PLANNERS_HARMONIC_POTENTIAL_H_

#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

namespace riskplan {

// A cell of the grid, (column, row).
struct GridCell {
  int i = 0;
  int j = 0;
  bool operator==(const GridCell&) const = default;
};

// Not thread-safe.
class HarmonicPotential {
 public:
  // An nx x ny grid of free cells, all at v = 0, surrounded by obstacles.
  // REQUIRES: nx, ny >= 1.
  HarmonicPotential(int nx, int ny);

  int nx() const { return nx_; }
  int ny() const { return ny_; }

  // Fixes a cell: an obstacle (v = 0, u = 1) or the goal (v = 1, u = 0), or
  // frees it again (keeping its value as the start of the relaxation). Changes
  // take effect at the next sweep, which continues from the current values.
  // REQUIRES: 0 <= i < nx, 0 <= j < ny.
  void SetObstacle(int i, int j);
  void SetGoal(int i, int j);
  void SetFree(int i, int j);
  bool IsObstacle(int i, int j) const;

  // One red-black SOR sweep over the free cells with factor omega in
  // (0, 2). Returns true when no free cell's value changed by more than
  // tolerance * |new value| (a free cell moving off exactly 0 counts as a
  // change).
  bool Sweep(double omega, double tolerance);

  // v = 1 - u of a cell (0 outside the grid).
  double Value(int i, int j) const;
  // Seed 002's potential u = 1 - v, rounded to double (for comparison).
  double Potential(int i, int j) const { return 1.0 - Value(i, j); }

  // The descent from `from`: each step moves to the 4-neighbour with the
  // highest v (lowest u), ties broken east, north, west, south, as long as it
  // is strictly higher than the current cell's. Returns the cells from `from`
  // to the goal, or nullopt when the descent stops elsewhere (a plateau or a
  // local maximum: the potential has not converged far enough, or `from`
  // cannot reach the goal, where v is 0).
  std::optional<std::vector<GridCell>> Descend(GridCell from) const;

  // The optimal SOR factor for an nx x ny rectangle (see the file comment).
  static double OptimalOmega(int nx, int ny);

 private:
  enum : uint8_t { kFree = 0, kObstacle = 1, kGoal = 2 };
  size_t Index(int i, int j) const {
    return static_cast<size_t>(j + 1) * stride_ + static_cast<size_t>(i + 1);
  }

  int nx_;
  int ny_;
  size_t stride_;
  // (nx + 2) x (ny + 2): a border ring of obstacles around the grid.
  std::vector<double> value_;
  std::vector<uint8_t> kind_;
};

}  // namespace riskplan

#endif  // RISKPLAN_CORE_PLANNERS_HARMONIC_POTENTIAL_H_
