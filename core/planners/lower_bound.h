// RiskLowerBound: a risk no admissible trajectory from a start to a goal can
// go below, computed from the map.
//
// Why it holds (spec sections 3, 4 and 6):
// 1. Per block. The map is cut into square blocks of side `block_m`. For a
//    sample q within d_step / 2 of a block (horizontally), every term of M(q)
//    is bounded: its height bin b is one of those of the flight band
//    [min_agl, max_agl], its air-heading bin k one of N_theta; its impact
//    cell lies within the block's reach shifted by o(b, k), so the impact
//    factor I is at least the kernel's EWMM over a density layer min-filtered
//    over that reach, and the expected shelter at most the EWMM over a
//    max-filtered shelter layer (p_cas falls as shelter rises). So M(q) >=
//    m_B = min over (b, k) of A_exp(b, k) p_cas(E(b, k), S_max) I_min: the
//    model's own FromSums on the filtered layers at the block's centre. A
//    window that reaches past the filtered map counts 0.
// 2. Along a trajectory. Its risk is lambda sum(M(q_k) ds / gs_k) over
//    midpoints spaced ds <= d_step apart along the 3-D arc, with gs <= v + W.
//    Every point of the arc lies within ds / 2 of its part's midpoint, so the
//    risk is at least the integral over the horizontal track of
//    rho_B = lambda m_B / (v + W) of the block under each point.
// 3. Over every track. Follow a track from the start's block B_0 and mark
//    B_{i+1}, the first block it enters `ring` (K) blocks away (Chebyshev)
//    from B_i. Between two marks it stays within K - 1 blocks of B_i (a
//    continuous track changes its block by one at a time), so that stretch
//    costs at least the least rho over those blocks times the least distance
//    from B_i to B_{i+1} (from the start point for the first stretch); the
//    last stretch, to the goal, at least the same least rho times the
//    distance from B_n to the goal. The bound is Dijkstra over the blocks
//    with those costs (or, when the goal's block is within K - 1 blocks of
//    the start's, the start's least rho times their distance, if lower). A
//    block wholly no-fly (its reach included) is never entered.
// What makes it loose: the best height and heading of each block taken
// anywhere in it, the filtered layers (a block reads its reach's least
// density), the least rho over K - 1 blocks around each mark, the ground
// speed v + W everywhere, and a stretch of K blocks counted as K - 1 (a
// straight track in a uniform field gets (K - 1) / K of its cost).
//
// Build() depends on the model and the block only, so one bound serves every
// start and goal of a model. Immutable once built; Query() is thread-safe.
#ifndef RISKPLAN_CORE_PLANNERS_LOWER_BOUND_H_
#define RISKPLAN_CORE_PLANNERS_LOWER_BOUND_H_

#include <memory>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/risk/risk_model.h"

namespace riskplan {

struct LowerBoundOptions {
  double block_m = 50.0;  // at least one map cell, at most the map's side
  int ring = 3;           // K, blocks between marks, [2, 16]
};

class RiskLowerBound {
 public:
  // InvalidArgument naming block_m or ring when out of range.
  static absl::StatusOr<std::unique_ptr<RiskLowerBound>> Build(
      std::shared_ptr<const RiskModel> model, const LowerBoundOptions& options = {});

  // The bound for any admissible trajectory from `start` to `goal` (points
  // of the map): expected casualties per flight, >= 0; +inf when no track
  // joins them without crossing closed blocks.
  double Query(const Pose& start, const Pose& goal) const;

  // Risk per metre of track of block (bi, bj); +inf: closed.
  double BlockRate(int bi, int bj) const { return rate_[bj * nbx_ + bi]; }
  // The least BlockRate within ring - 1 blocks of (bi, bj).
  double RingRate(int bi, int bj) const { return ring_rate_[bj * nbx_ + bi]; }
  int blocks_x() const { return nbx_; }
  int blocks_y() const { return nby_; }
  double block_m() const { return block_m_; }
  size_t MemoryBytes() const { return (rate_.capacity() + ring_rate_.capacity()) * sizeof(double); }

 private:
  RiskLowerBound() = default;

  std::shared_ptr<const RiskModel> model_;
  double block_m_ = 0.0;
  int ring_ = 3;
  int nbx_ = 0;
  int nby_ = 0;
  std::vector<double> rate_;
  std::vector<double> ring_rate_;
};

}  // namespace riskplan

#endif  // RISKPLAN_CORE_PLANNERS_LOWER_BOUND_H_
