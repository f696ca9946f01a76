// Two-tier feasibility (seed 001, Allaire, Langlois, Labonte, Tarbouchi): a
// path's first segments are checked against the detailed terrain grid, the
// rest against a coarse grid that holds the maximum of each 16 x 16 block, the
// cells of each segment enumerated by a Bresenham-style traversal, a
// collision being an altitude at or below the terrain.
//
// riskplan's checker is conservative in both tiers, which the seed's is not
// (it only needs to be, for a genetic planner, mostly right):
// - the default traversal enumerates every cell the segment touches (the
//   supercover of Bresenham's line, stepped with Bresenham's incremental
//   error on real coordinates); seed 001's one-cell-per-step Bresenham is
//   available and misses the cells a segment clips at a corner;
// - each cell is compared with the lowest (and highest) altitude the segment
//   has inside it, not its altitude at one point;
// - the coarse tier pools the floor with max and the ceiling with min, and
//   values are rounded outwards to float.
// So with the supercover traversal, "feasible" implies that every point of
// every segment passes the cell rule: in particular every sample that the
// exact check of spec section 6 takes (tested). The coarse tier may call a
// feasible path infeasible (a block's highest cell stands for all of it);
// result.tier says which tier found the collision.
#ifndef RISKPLAN_CORE_PLANNERS_TWO_TIER_FEASIBILITY_H_
#define RISKPLAN_CORE_PLANNERS_TWO_TIER_FEASIBILITY_H_

#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "core/base/geometry.h"
#include "core/flight/trajectory.h"
#include "core/risk/risk_model.h"

namespace riskplan {

enum class FeasibilityTier { kNone = 0, kDetailed = 1, kCoarse = 2 };
// "NONE", "DETAILED", "COARSE".
std::string_view FeasibilityTierName(FeasibilityTier tier);

enum class CollisionRule {
  // Seed 001: a collision is z <= terrain (and any point outside the map).
  kTerrain = 0,
  // Spec section 6 per cell: outside the map, no-fly, z <= terrain,
  // z < safe altitude or z > terrain + max_agl; near the edges, z above the
  // height where a fall's impact window may reach past the map (the model's
  // WindowCeilingAgl(), whole-cell margins per height bin, conservative).
  kFlightBand = 1,
};

enum class CellTraversal {
  kSupercover = 0,  // every cell the segment touches (conservative)
  kBresenham = 1,   // seed 001: one cell per step along the major axis
};

struct TwoTierOptions {
  CollisionRule rule = CollisionRule::kFlightBand;
  // Segments (or trajectory pieces) checked against the detailed grid, from
  // the first; the rest use the coarse grid. Seed 001 uses 2.
  int detailed_segments = 2;
  // Side of a coarse block, in map cells (seed 001: 16).
  int block_cells = 16;
  CellTraversal traversal = CellTraversal::kSupercover;
};

// InvalidArgument unless detailed_segments >= 0 and 1 <= block_cells <= 1024.
absl::Status CheckTwoTierOptions(const TwoTierOptions& options);

struct FeasibilityResult {
  bool feasible = true;
  // The tier that found the first collision (kNone when feasible).
  FeasibilityTier tier = FeasibilityTier::kNone;
  int segment = -1;  // index of the segment (or piece) of the first collision
  // Cell of the first collision in that tier's grid (a block for kCoarse).
  int cell_i = -1;
  int cell_j = -1;
  Point3 position;  // where the segment enters that cell
  // kOutsideMap, kNoFlyZone, kImpactOutsideMap, kTerrainCollision,
  // kBelowSafeAltitude or kAboveMaxAltitude. For the coarse tier it names the pooled limit broken
  // (kTerrainCollision or kBelowSafeAltitude for the floor, kAboveMaxAltitude).
  ViolationKind kind = ViolationKind::kNone;
  int64_t cells_checked = 0;    // cells compared, both tiers
  int64_t colliding_cells = 0;  // all of them when counting, else 0 or 1
};

// Immutable once built; thread-safe. Holds 8 bytes per map cell (kFlightBand)
// or 4 (kTerrain), and 1/256 of that for the coarse tier.
class TwoTierFeasibility {
 public:
  // REQUIRES: CheckTwoTierOptions(options).ok().
  TwoTierFeasibility(const RiskModel& model, TwoTierOptions options = {});

  const TwoTierOptions& options() const { return options_; }
  // Bytes of both tiers' layers.
  size_t MemoryBytes() const;

  // A polyline: segment k joins path[k] and path[k + 1], z linear along it.
  // Stops at the first collision unless `count_all`, which counts every
  // colliding cell (the GA's collision cost).
  FeasibilityResult CheckPath(std::span<const Point3> path, bool count_all = false) const;

  // A trajectory: piece k is checked along the polyline through its samples
  // of spec section 6 (start, midpoints, end), in the tier of index k.
  FeasibilityResult CheckTrajectory(std::span<const TrajectoryPiece> pieces,
                                    bool count_all = false) const;

 private:
  struct Tier {
    FeasibilityTier which = FeasibilityTier::kDetailed;
    int nx = 0;
    int ny = 0;
    double cell_m = 1.0;
    std::vector<float> floor;    // collision below (at, for kTerrain) this
    std::vector<float> ceiling;  // collision above this (kFlightBand only)
  };

  // Checks segment a -> b against `tier`; returns true to stop.
  bool CheckSegment(const Tier& tier, const Point3& a, const Point3& b, int segment, bool count_all,
                    FeasibilityResult* result) const;
  // Compares cell (i, j) with altitudes [z_low, z_high]; true on collision.
  bool CellCollides(const Tier& tier, int i, int j, double z_low, double z_high,
                    ViolationKind* kind) const;
  const Tier& TierOf(int segment) const {
    return segment < options_.detailed_segments ? detailed_ : coarse_;
  }

  const RiskModel& model_;
  TwoTierOptions options_;
  Tier detailed_;
  Tier coarse_;
};

}  // namespace riskplan

#endif  // RISKPLAN_CORE_PLANNERS_TWO_TIER_FEASIBILITY_H_
