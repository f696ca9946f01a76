#include "core/planners/two_tier_feasibility.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

#include "absl/strings/str_format.h"
#include "core/base/check.h"

namespace riskplan {
namespace {

constexpr float kFloatInf = std::numeric_limits<float>::infinity();

// The next float above (below) a finite f, by its bits: much cheaper than
// std::nextafter in the per-cell loops.
float NextUp(float f) {
  if (f == 0.0f) return std::numeric_limits<float>::denorm_min();
  const uint32_t bits = std::bit_cast<uint32_t>(f);
  return std::bit_cast<float>(f > 0.0f ? bits + 1 : bits - 1);
}
float NextDown(float f) { return -NextUp(-f); }

// The float nearest to d that is >= d (<= d): rounding limits outwards keeps
// the float comparison at least as strict as the double one.
float RoundUp(double d) {
  const float f = static_cast<float>(d);
  return static_cast<double>(f) < d && std::isfinite(f) ? NextUp(f) : f;
}
float RoundDown(double d) {
  const float f = static_cast<float>(d);
  return static_cast<double>(f) > d && std::isfinite(f) ? NextDown(f) : f;
}

// Altitudes of a segment inside a cell are compared with a tolerance this
// large, so that rounding in the traversal's crossing parameters cannot let a
// sample of the exact check slip between two cells' altitude ranges.
constexpr double kAltitudeSlackM = 1e-6;

}  // namespace

std::string_view FeasibilityTierName(FeasibilityTier tier) {
  switch (tier) {
    case FeasibilityTier::kNone:
      return "NONE";
    case FeasibilityTier::kDetailed:
      return "DETAILED";
    case FeasibilityTier::kCoarse:
      return "COARSE";
  }
  return "UNKNOWN";
}

absl::Status CheckTwoTierOptions(const TwoTierOptions& options) {
  if (options.detailed_segments < 0) {
    return absl::InvalidArgumentError(
        absl::StrFormat("two-tier feasibility: detailed_segments is %d; it must be >= 0",
                        options.detailed_segments));
  }
  if (options.block_cells < 1 || options.block_cells > 1024) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "two-tier feasibility: block_cells is %d; it must be in [1, 1024]", options.block_cells));
  }
  return absl::OkStatus();
}

TwoTierFeasibility::TwoTierFeasibility(const RiskModel& model, TwoTierOptions options)
    : model_(model), options_(options) {
  RISKPLAN_DCHECK(CheckTwoTierOptions(options).ok());
  const RiskMap& map = model.map();
  const bool band = options.rule == CollisionRule::kFlightBand;
  const size_t cells = static_cast<size_t>(map.nx()) * map.ny();
  detailed_.which = FeasibilityTier::kDetailed;
  detailed_.nx = map.nx();
  detailed_.ny = map.ny();
  detailed_.cell_m = map.res();
  detailed_.floor.resize(cells);
  if (band) detailed_.ceiling.resize(cells);
  const double max_agl = model.params().max_agl_m;
  for (int j = 0; j < map.ny(); ++j) {
    for (int i = 0; i < map.nx(); ++i) {
      const int64_t k = map.Index(i, j);
      const float terrain_f = map.terrain(i, j);
      if (!band) {
        detailed_.floor[k] = terrain_f;  // exact: the layer is float
        continue;
      }
      if (map.nofly(i, j)) {
        detailed_.floor[k] = kFloatInf;
        detailed_.ceiling[k] = -kFloatInf;
        continue;
      }
      // z <= terrain or z < safe altitude <=> z < max(next double above
      // terrain, safe altitude); the safe altitude is above the terrain
      // unless min_agl is 0.
      const double terrain = terrain_f;
      const double safe = model.SafeAltitude(i, j);
      const double floor_d =
          safe > terrain ? safe : std::nextafter(terrain, std::numeric_limits<double>::infinity());
      detailed_.floor[k] = std::isinf(floor_d) ? kFloatInf : RoundUp(floor_d);
      // Near the edges the ceiling is lower: above it a fall's impact window
      // may reach past the map at some heading (spec version 2).
      detailed_.ceiling[k] =
          RoundDown(std::min(terrain + max_agl, terrain + model.WindowCeilingAgl(i, j)));
    }
  }
  const int b = options.block_cells;
  coarse_.which = FeasibilityTier::kCoarse;
  coarse_.nx = (map.nx() + b - 1) / b;
  coarse_.ny = (map.ny() + b - 1) / b;
  coarse_.cell_m = map.res() * b;
  coarse_.floor.assign(static_cast<size_t>(coarse_.nx) * coarse_.ny, -kFloatInf);
  if (band) coarse_.ceiling.assign(coarse_.floor.size(), kFloatInf);
  for (int j = 0; j < map.ny(); ++j) {
    float* floor_row = coarse_.floor.data() + static_cast<size_t>(j / b) * coarse_.nx;
    float* ceiling_row =
        band ? coarse_.ceiling.data() + static_cast<size_t>(j / b) * coarse_.nx : nullptr;
    const float* detailed_floor = detailed_.floor.data() + map.Index(0, j);
    const float* detailed_ceiling = band ? detailed_.ceiling.data() + map.Index(0, j) : nullptr;
    for (int i0 = 0, c = 0; i0 < map.nx(); i0 += b, ++c) {
      const int i1 = std::min(i0 + b, map.nx());
      float f = floor_row[c];
      for (int i = i0; i < i1; ++i) f = std::max(f, detailed_floor[i]);
      floor_row[c] = f;
      if (band) {
        float g = ceiling_row[c];
        for (int i = i0; i < i1; ++i) g = std::min(g, detailed_ceiling[i]);
        ceiling_row[c] = g;
      }
    }
  }
}

bool TwoTierFeasibility::CellCollides(const Tier& tier, int i, int j, double z_low, double z_high,
                                      ViolationKind* kind) const {
  if (i < 0 || j < 0 || i >= tier.nx || j >= tier.ny) {
    *kind = ViolationKind::kOutsideMap;
    return true;
  }
  const size_t k = static_cast<size_t>(j) * tier.nx + i;
  if (options_.rule == CollisionRule::kTerrain) {
    if (z_low - kAltitudeSlackM <= tier.floor[k]) {
      *kind = ViolationKind::kTerrainCollision;
      return true;
    }
    return false;
  }
  const bool below = z_low - kAltitudeSlackM < tier.floor[k];
  const bool above = z_high + kAltitudeSlackM > tier.ceiling[k];
  if (!below && !above) return false;
  if (tier.which == FeasibilityTier::kCoarse) {
    *kind = below ? ViolationKind::kBelowSafeAltitude : ViolationKind::kAboveMaxAltitude;
    return true;
  }
  const RiskMap& map = model_.map();
  if (map.nofly(i, j)) {
    *kind = ViolationKind::kNoFlyZone;
  } else if (z_low - kAltitudeSlackM <= map.terrain(i, j)) {
    *kind = ViolationKind::kTerrainCollision;
  } else if (below) {
    *kind = ViolationKind::kBelowSafeAltitude;
  } else {
    // Above the band's top, or above the lower ceiling near the edges.
    const float max_ceiling = RoundDown(map.terrain(i, j) + model_.params().max_agl_m);
    *kind = z_high + kAltitudeSlackM > max_ceiling ? ViolationKind::kAboveMaxAltitude
                                                   : ViolationKind::kImpactOutsideMap;
  }
  return true;
}

bool TwoTierFeasibility::CheckSegment(const Tier& tier, const Point3& a, const Point3& b,
                                      int segment, bool count_all,
                                      FeasibilityResult* result) const {
  const RiskMap& map = model_.map();
  // Grid coordinates in units of the tier's cells.
  const double gx0 = (a.x - map.x0()) / tier.cell_m;
  const double gy0 = (a.y - map.y0()) / tier.cell_m;
  const double gx1 = (b.x - map.x0()) / tier.cell_m;
  const double gy1 = (b.y - map.y0()) / tier.cell_m;
  const double dz = b.z - a.z;
  auto visit = [&](int i, int j, double t0, double t1) {
    ++result->cells_checked;
    const double za = a.z + t0 * dz;
    const double zb = a.z + t1 * dz;
    ViolationKind kind = ViolationKind::kNone;
    if (!CellCollides(tier, i, j, std::min(za, zb), std::max(za, zb), &kind)) return false;
    ++result->colliding_cells;
    if (result->feasible) {
      result->feasible = false;
      result->tier = tier.which;
      result->segment = segment;
      result->cell_i = i;
      result->cell_j = j;
      result->position = Point3{a.x + t0 * (b.x - a.x), a.y + t0 * (b.y - a.y), za};
      result->kind = kind;
    }
    return !count_all;
  };
  // The map is a rectangle, so a segment lies inside it exactly when both
  // ends do. (The coarse grid's last blocks may reach past the map's edge.)
  int unused_i = 0, unused_j = 0;
  if (!std::isfinite(a.z) || !map.CellOf(a.x, a.y, &unused_i, &unused_j)) {
    visit(-1, -1, 0.0, 0.0);
    return !count_all;
  }
  if (!std::isfinite(b.z) || !map.CellOf(b.x, b.y, &unused_i, &unused_j)) {
    visit(-1, -1, 1.0, 1.0);
    return !count_all;
  }
  int i = static_cast<int>(std::floor(gx0));
  int j = static_cast<int>(std::floor(gy0));
  const int i_end = static_cast<int>(std::floor(gx1));
  const int j_end = static_cast<int>(std::floor(gy1));

  if (options_.traversal == CellTraversal::kBresenham) {
    // Seed 001: integer Bresenham between the end cells, one cell per step of
    // the major axis, compared at the segment's altitude at that step.
    const int di = std::abs(i_end - i), dj = std::abs(j_end - j);
    const int si = i < i_end ? 1 : -1, sj = j < j_end ? 1 : -1;
    const int steps = std::max(di, dj);
    int err = di - dj;
    for (int k = 0;; ++k) {
      const double t = steps > 0 ? static_cast<double>(k) / steps : 0.0;
      if (visit(i, j, t, t)) return true;
      if (i == i_end && j == j_end) return false;
      const int e2 = 2 * err;
      if (e2 > -dj) {
        err -= dj;
        i += si;
      }
      if (e2 < di) {
        err += di;
        j += sj;
      }
    }
  }

  // Supercover: step from cell to cell at each crossing of a grid line, in
  // order of the segment parameter t (Bresenham's incremental stepping on
  // real coordinates). The number of steps is fixed by the end cells, so the
  // walk always ends in the last cell whatever the rounding.
  const double dx = gx1 - gx0;
  const double dy = gy1 - gy0;
  const int si = dx > 0 ? 1 : -1;
  const int sj = dy > 0 ? 1 : -1;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const double tdx = dx != 0.0 ? 1.0 / std::abs(dx) : kInf;
  const double tdy = dy != 0.0 ? 1.0 / std::abs(dy) : kInf;
  double tmx = dx > 0 ? (i + 1 - gx0) * tdx : (dx < 0 ? (gx0 - i) * tdx : kInf);
  double tmy = dy > 0 ? (j + 1 - gy0) * tdy : (dy < 0 ? (gy0 - j) * tdy : kInf);
  int left_i = std::abs(i_end - i);
  int left_j = std::abs(j_end - j);
  double t = 0.0;
  constexpr double kCornerT = 1e-12;
  while (left_i > 0 || left_j > 0) {
    const bool corner = left_i > 0 && left_j > 0 && std::abs(tmx - tmy) <= kCornerT;
    const bool step_i = left_j == 0 || (left_i > 0 && tmx < tmy);
    const double t_next = std::clamp(corner ? std::min(tmx, tmy) : (step_i ? tmx : tmy), t, 1.0);
    if (visit(i, j, t, t_next)) return true;
    t = t_next;
    if (corner) {
      // Through a corner (up to rounding): both side cells touch the segment.
      if (visit(i + si, j, t, t) || visit(i, j + sj, t, t)) return true;
      i += si;
      j += sj;
      tmx += tdx;
      tmy += tdy;
      --left_i;
      --left_j;
    } else if (step_i) {
      i += si;
      tmx += tdx;
      --left_i;
    } else {
      j += sj;
      tmy += tdy;
      --left_j;
    }
  }
  return visit(i, j, t, 1.0);
}

FeasibilityResult TwoTierFeasibility::CheckPath(std::span<const Point3> path,
                                                bool count_all) const {
  FeasibilityResult result;
  for (size_t k = 0; k + 1 < path.size(); ++k) {
    const int segment = static_cast<int>(k);
    if (CheckSegment(TierOf(segment), path[k], path[k + 1], segment, count_all, &result)) break;
  }
  return result;
}

FeasibilityResult TwoTierFeasibility::CheckTrajectory(std::span<const TrajectoryPiece> pieces,
                                                      bool count_all) const {
  FeasibilityResult result;
  const ModelParams& params = model_.params();
  std::vector<Pose> samples;
  for (size_t p = 0; p < pieces.size(); ++p) {
    // The admissibility samples (start, midpoints, end), joined by chords.
    const PieceRisk rule(pieces[p], params.sample_step_m, params);
    samples.clear();
    for (int64_t i = 0; i < rule.admissibility_samples(); ++i) {
      samples.push_back(rule.AdmissibilitySample(i));
    }
    const int segment = static_cast<int>(p);
    const Tier& tier = TierOf(segment);
    for (size_t k = 0; k + 1 < samples.size(); ++k) {
      const Point3 a{samples[k].x, samples[k].y, samples[k].z};
      const Point3 b{samples[k + 1].x, samples[k + 1].y, samples[k + 1].z};
      if (CheckSegment(tier, a, b, segment, count_all, &result)) return result;
    }
  }
  return result;
}

size_t TwoTierFeasibility::MemoryBytes() const {
  return (detailed_.floor.size() + detailed_.ceiling.size() + coarse_.floor.size() +
          coarse_.ceiling.size()) *
         sizeof(float);
}

}  // namespace riskplan
