#include "core/risk/risk_model.h"

#include <algorithm>
#include <cmath>

#if defined(__x86_64__)
#include <immintrin.h>
#endif
#include <limits>

#include "absl/strings/str_format.h"
#include "core/base/check.h"

namespace riskplan {
namespace {

// Steps 1-3 of spec section 3 for a q inside the map (cell (i, j)) and above
// its terrain by h > 0, with a finite heading: the bins (the heading bin of
// the air heading, version 3) and the impact cell, whether or not the window
// lies inside the map.
KernelSite SiteOf(const RiskMap& map, const ImpactTable& table, int heading_bin, const Pose& q,
                  double h) {
  KernelSite site;
  site.height_bin = table.HeightBinOf(h);
  site.heading_bin = heading_bin;
  const ImpactKernel& kernel = table.kernel(site.height_bin, site.heading_bin);
  site.impact_i = static_cast<int>(std::floor((q.x + kernel.offset_x_m - map.x0()) / map.res()));
  site.impact_j = static_cast<int>(std::floor((q.y + kernel.offset_y_m - map.y0()) / map.res()));
  return site;
}

// Widens `m` to hold `other` as well.
void Widen(const CellMargins& other, CellMargins* m) {
  m->west = std::max(m->west, other.west);
  m->east = std::max(m->east, other.east);
  m->south = std::max(m->south, other.south);
  m->north = std::max(m->north, other.north);
}

// Widens `m` over height bin b and every heading bin. The impact cell of a
// configuration in cell i is floor(i + f + o/res) for some f in [0, 1), that
// is i + floor(o/res) or one more; one cell more on each side absorbs the
// rounding of the division.
void WidenOverBin(const ImpactTable& table, int b, CellMargins* m) {
  const double res = table.res_m();
  for (int k = 0; k < table.heading_bins(); ++k) {
    const ImpactKernel& kernel = table.kernel(b, k);
    const int hw = kernel.half_width;
    const int fx = static_cast<int>(std::floor(kernel.offset_x_m / res));
    const int fy = static_cast<int>(std::floor(kernel.offset_y_m / res));
    Widen(CellMargins{hw + 1 - fx, hw + 2 + fx, hw + 1 - fy, hw + 2 + fy}, m);
  }
}

}  // namespace

double ImpactReach::Max() const { return std::max({west_m, east_m, south_m, north_m}); }

int64_t ImpactReach::CellsClear(const RiskMap& map) const {
  const auto clear = [&](int n, double back_m, double ahead_m) {
    int64_t count = 0;
    for (int i = 0; i < n; ++i) {
      const double centre = (i + 0.5) * map.res();
      if (centre >= back_m && n * map.res() - centre > ahead_m) ++count;
    }
    return count;
  };
  return clear(map.nx(), west_m, east_m) * clear(map.ny(), south_m, north_m);
}

std::string_view ViolationKindName(ViolationKind kind) {
  switch (kind) {
    case ViolationKind::kNone:
      return "NONE";
    case ViolationKind::kOutsideMap:
      return "OUTSIDE_MAP";
    case ViolationKind::kNoFlyZone:
      return "NO_FLY_ZONE";
    case ViolationKind::kTerrainCollision:
      return "TERRAIN_COLLISION";
    case ViolationKind::kBelowSafeAltitude:
      return "BELOW_SAFE_ALTITUDE";
    case ViolationKind::kAboveMaxAltitude:
      return "ABOVE_MAX_ALTITUDE";
    case ViolationKind::kImpactOutsideMap:
      return "IMPACT_OUTSIDE_MAP";
  }
  return "UNKNOWN";
}

absl::StatusOr<std::shared_ptr<const RiskModel>> RiskModel::Create(
    std::shared_ptr<const RiskMap> map, const ModelParams& params,
    std::shared_ptr<const ImpactTable> table, const ModelBuildLimits& limits) {
  if (map == nullptr) return absl::InvalidArgumentError("risk model: no map");
  if (absl::Status s = ValidateModelParams(params); !s.ok()) return s;
  if (params.max_half_width > RiskMap::kPad) {
    return absl::InvalidArgumentError(
        absl::StrFormat("parameter 'max_half_width' (%d) exceeds the largest supported (%d)",
                        params.max_half_width, RiskMap::kPad));
  }
  if (table != nullptr &&
      (!SameKernelParams(table->params(), params) || table->res_m() != map->res())) {
    return absl::InvalidArgumentError(
        "risk model: the impact table given was built for other parameters or cell size");
  }
  if (table != nullptr && !SameImpactTableParams(table->params(), params)) {
    // Another wind: share its weights, compute the offsets and energies.
    absl::StatusOr<std::shared_ptr<const ImpactTable>> in_wind = ImpactTable::InWind(*table, params);
    if (!in_wind.ok()) return in_wind.status();
    table = *std::move(in_wind);
  }
  if (table == nullptr) {
    absl::StatusOr<std::shared_ptr<const ImpactTable>> built =
        ImpactTable::Build(params, map->res(), limits);
    if (!built.ok()) return built.status();
    table = *std::move(built);
  }
  auto model = std::shared_ptr<RiskModel>(new RiskModel());
  model->map_ = std::move(map);
  model->table_ = std::move(table);
  model->params_ = params;
  model->wind_ = WindTriangle(params);
  if (params.Calm() && model->map_->glide_ratio() == params.glide_ratio &&
      model->map_->glide_clearance_m() == params.glide_clearance_m) {
    model->glide_ = &model->map_->glide_altitude();
  } else {
    const RiskMap& m = *model->map_;
    const WindVector w = WindVectorOf(params.wind_speed_mps, params.wind_from_deg);
    absl::StatusOr<std::vector<double>> glide = ComputeGlideAltitude(
        m.nx(), m.ny(), m.res(), m.layers().terrain, m.nofly_layer(), m.landing_sites(),
        params.glide_ratio, params.glide_clearance_m, limits.stop,
        GlideWind{.x = w.x, .y = w.y, .airspeed_mps = params.GlideAirspeed()});
    if (!glide.ok()) return glide.status();
    model->own_glide_ = std::make_shared<const std::vector<double>>(*std::move(glide));
    model->glide_ = model->own_glide_.get();
  }
  const ImpactTable& t = *model->table_;
  if (!params.Calm()) model->BuildAirBins();
  model->first_band_bin_ = t.HeightBinOf(params.min_agl_m);
  CellMargins upto;
  for (int b = model->first_band_bin_; b <= t.HeightBinOf(params.max_agl_m); ++b) {
    WidenOverBin(t, b, &upto);
    model->margins_upto_.push_back(upto);
  }
  model->band_margins_ = upto;
  return std::shared_ptr<const RiskModel>(std::move(model));
}

absl::StatusOr<std::shared_ptr<const RiskModel>> RiskModel::WithMap(
    const RiskModel& from, std::shared_ptr<const RiskMap> map, const StopCondition& stop,
    GlideRepairStats* stats) {
  if (map == nullptr) return absl::InvalidArgumentError("risk model: no map");
  if (!map->SharesLayersWith(*from.map_)) {
    return absl::InvalidArgumentError(
        "risk model: the map given does not share the model's map layers (RiskMap::WithNoFly)");
  }
  auto model = std::shared_ptr<RiskModel>(new RiskModel(from));
  if (from.own_glide_ == nullptr) {
    // From reads its map's layer (Create's rule), so this one reads its map's.
    model->own_glide_ = nullptr;
    model->glide_ = &map->glide_altitude();
    if (stats != nullptr) *stats = GlideRepairStats{};
  } else {
    const ModelParams& p = from.params_;
    const WindVector w = WindVectorOf(p.wind_speed_mps, p.wind_from_deg);
    std::vector<double> glide = *from.own_glide_;
    if (absl::Status s = RepairGlideAltitude(
            map->nx(), map->ny(), map->res(), map->layers().terrain, map->landing_sites(),
            p.glide_ratio, p.glide_clearance_m,
            GlideWind{.x = w.x, .y = w.y, .airspeed_mps = p.GlideAirspeed()},
            from.map_->nofly_layer(), map->nofly_layer(), &glide, stop, stats);
        !s.ok()) {
      return s;
    }
    model->own_glide_ = std::make_shared<const std::vector<double>>(std::move(glide));
    model->glide_ = model->own_glide_.get();
  }
  model->map_ = std::move(map);
  return std::shared_ptr<const RiskModel>(std::move(model));
}

void RiskModel::BuildAirBins() {
  // Each interval [a, b) of track headings gets the bin of its ends' air
  // headings when both are the same bin and lie more than kGuardRad inside
  // it: psi(theta) is increasing (W < v), so every track heading of the
  // interval has its air heading between those of the ends, and the
  // rounding of AirHeading (a few 1e-16 rad) cannot reach a bin boundary.
  // Otherwise -1: the bin is computed exactly.
  constexpr double kGuardRad = 1e-9;
  const ImpactTable& t = *table_;
  const double width = kTwoPi / t.heading_bins();
  const auto inside = [&](double psi) {  // distance to the nearest bin boundary, rad
    const double u = psi / width + 0.5;
    const double f = u - std::floor(u);
    return std::min(f, 1.0 - f) * width;
  };
  air_bins_.assign(kAirBinCells, -1);
  for (int c = 0; c < kAirBinCells; ++c) {
    const double a = kTwoPi * c / kAirBinCells;
    const double b = kTwoPi * (c + 1) / kAirBinCells;
    const double psi_a = wind_.AirHeading(a);
    const double psi_b = wind_.AirHeading(b);
    const int bin_a = t.HeadingBinOf(psi_a);
    if (bin_a != t.HeadingBinOf(psi_b)) continue;
    if (!(inside(psi_a) > kGuardRad && inside(psi_b) > kGuardRad)) continue;
    // Less than half a bin apart (around the circle): no boundary between.
    double span = std::fabs(psi_b - psi_a);
    span = std::min(span, kTwoPi - span);
    if (!(span < 0.5 * width)) continue;
    air_bins_[c] = static_cast<int16_t>(bin_a);
  }
}

double RiskModel::WindowCeilingAgl(int i, int j) const {
  const int nx = map_->nx();
  const int ny = map_->ny();
  if (band_margins_.Inside(i, j, nx, ny)) return std::numeric_limits<double>::infinity();
  // The margins only grow with the height bin: the last bin whose margins
  // hold the cell.
  size_t n = 0;
  while (n < margins_upto_.size() && margins_upto_[n].Inside(i, j, nx, ny)) ++n;
  if (n == 0) return -std::numeric_limits<double>::infinity();
  // Heights h < (b + 1/2) dh round to bin b or lower (spec step 2); a small
  // margin keeps the division's rounding from reaching bin b + 1.
  const int b = first_band_bin_ + static_cast<int>(n) - 1;
  return (b + 0.5 - 1e-9) * table_->params().height_bin_m;
}

double RiskModel::SafeAltitude(int i, int j) const {
  RISKPLAN_DCHECK(map_->Contains(i, j));
  const double floor_alt = static_cast<double>(map_->terrain(i, j)) + params_.min_agl_m;
  if (map_->landing_sites().empty()) return floor_alt;
  return std::max(floor_alt, (*glide_)[map_->Index(i, j)]);
}

ViolationKind RiskModel::CheckBeforeWindow(const Pose& q, double* limit_m, double* height_m,
                                           int* cell_i, int* cell_j) const {
  if (limit_m != nullptr) *limit_m = std::numeric_limits<double>::quiet_NaN();
  int i = 0;
  int j = 0;
  if (!std::isfinite(q.z) || !std::isfinite(q.theta) || !map_->CellOf(q.x, q.y, &i, &j)) {
    return ViolationKind::kOutsideMap;
  }
  if (map_->nofly(i, j)) return ViolationKind::kNoFlyZone;
  const double terrain = map_->terrain(i, j);
  if (q.z <= terrain) {
    if (limit_m != nullptr) *limit_m = terrain;
    return ViolationKind::kTerrainCollision;
  }
  const double safe = SafeAltitude(i, j);
  if (q.z < safe) {
    if (limit_m != nullptr) *limit_m = safe;
    return ViolationKind::kBelowSafeAltitude;
  }
  const double ceiling = terrain + params_.max_agl_m;
  if (q.z > ceiling) {
    if (limit_m != nullptr) *limit_m = ceiling;
    return ViolationKind::kAboveMaxAltitude;
  }
  *height_m = q.z - terrain;
  *cell_i = i;
  *cell_j = j;
  return ViolationKind::kNone;
}

ViolationKind RiskModel::CheckConfiguration(const Pose& q, double* limit_m) const {
  double h = 0.0;
  int i = 0;
  int j = 0;
  const ViolationKind kind = CheckBeforeWindow(q, limit_m, &h, &i, &j);
  if (kind != ViolationKind::kNone) return kind;
  // Last, as it needs the height bin: the impact window inside the map. A
  // sample that passed the band rules has its height bin in the flight band's,
  // so inside band_margins() its window is inside for every heading: the
  // same answer without locating it (most samples of a city's interior).
  if (band_margins_.Inside(i, j, map_->nx(), map_->ny())) return ViolationKind::kNone;
  if (!WindowInsideMap(SiteOf(*map_, *table_, AirHeadingBin(q.theta), q, h))) {
    return ViolationKind::kImpactOutsideMap;
  }
  return ViolationKind::kNone;
}

ViolationKind RiskModel::CheckConfiguration(const Pose& q, const ConfigurationRisk& m,
                                            double* limit_m) const {
  double h = 0.0;
  int i = 0;
  int j = 0;
  const ViolationKind kind = CheckBeforeWindow(q, limit_m, &h, &i, &j);
  if (kind != ViolationKind::kNone) return kind;
  // q is inside the map, finite and above the terrain: M(q) is undefined
  // only for its window (Locate).
  return m.defined ? ViolationKind::kNone : ViolationKind::kImpactOutsideMap;
}

namespace {

// The EWMM inner loops over padded layers. Each of the kKernelLanes = 8 lanes
// accumulates every 8th column of the kernel rows in a fixed order; the lanes
// are then added pairwise. The order of every addition is fixed by this code,
// and the build forbids contracting a*b+c into an FMA (-ffp-contract=off), so
// the portable loop and the AVX2 loop give the same result bit for bit.
static_assert(kKernelLanes == 8, "the EWMM loops add eight lanes");

inline double ReduceLanes(const double* a) {
  return ((a[0] + a[1]) + (a[2] + a[3])) + ((a[4] + a[5]) + (a[6] + a[7]));
}

void EwmmRowsPortable(const double* weights, int rows, int stride, const float* rho,
                      const float* shelter, int64_t map_stride, double* impact_factor,
                      double* expected_shelter) {
  double acc_rho[8] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  double acc_shelter[8] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  for (int v = 0; v < rows; ++v) {
    const double* w = weights + static_cast<int64_t>(v) * stride;
    const float* r = rho + v * map_stride;
    const float* s = shelter + v * map_stride;
    for (int u = 0; u < stride; u += 8) {
      for (int l = 0; l < 8; ++l) {
        acc_rho[l] += w[u + l] * static_cast<double>(r[u + l]);
        acc_shelter[l] += w[u + l] * static_cast<double>(s[u + l]);
      }
    }
  }
  *impact_factor = ReduceLanes(acc_rho);
  *expected_shelter = ReduceLanes(acc_shelter);
}

#if defined(__x86_64__)
// The same arithmetic as EwmmRowsPortable: lanes 0-3 in *_lo, 4-7 in *_hi.
__attribute__((target("avx2"))) void EwmmRowsAvx2(const double* weights, int rows, int stride,
                                                  const float* rho, const float* shelter,
                                                  int64_t map_stride, double* impact_factor,
                                                  double* expected_shelter) {
  __m256d rho_lo = _mm256_setzero_pd();
  __m256d rho_hi = _mm256_setzero_pd();
  __m256d sh_lo = _mm256_setzero_pd();
  __m256d sh_hi = _mm256_setzero_pd();
  for (int v = 0; v < rows; ++v) {
    const double* w = weights + static_cast<int64_t>(v) * stride;
    const float* r = rho + v * map_stride;
    const float* s = shelter + v * map_stride;
    for (int u = 0; u < stride; u += 8) {
      const __m256d w_lo = _mm256_loadu_pd(w + u);
      const __m256d w_hi = _mm256_loadu_pd(w + u + 4);
      rho_lo = _mm256_add_pd(rho_lo, _mm256_mul_pd(w_lo, _mm256_cvtps_pd(_mm_loadu_ps(r + u))));
      rho_hi = _mm256_add_pd(rho_hi, _mm256_mul_pd(w_hi, _mm256_cvtps_pd(_mm_loadu_ps(r + u + 4))));
      sh_lo = _mm256_add_pd(sh_lo, _mm256_mul_pd(w_lo, _mm256_cvtps_pd(_mm_loadu_ps(s + u))));
      sh_hi = _mm256_add_pd(sh_hi, _mm256_mul_pd(w_hi, _mm256_cvtps_pd(_mm_loadu_ps(s + u + 4))));
    }
  }
  alignas(32) double lanes[8];
  _mm256_store_pd(lanes, rho_lo);
  _mm256_store_pd(lanes + 4, rho_hi);
  *impact_factor = ReduceLanes(lanes);
  _mm256_store_pd(lanes, sh_lo);
  _mm256_store_pd(lanes + 4, sh_hi);
  *expected_shelter = ReduceLanes(lanes);
}
#endif

using EwmmRowsFn = void (*)(const double*, int, int, const float*, const float*, int64_t, double*,
                            double*);

EwmmRowsFn SelectEwmmRows() {
#if defined(__x86_64__)
  if (__builtin_cpu_supports("avx2")) return &EwmmRowsAvx2;
#endif
  return &EwmmRowsPortable;
}

const EwmmRowsFn kEwmmRows = SelectEwmmRows();

}  // namespace

void RiskModel::Ewmm(const ImpactKernel& kernel, int ci, int cj, double* impact_factor,
                     double* expected_shelter) const {
  const int hw = kernel.half_width;
  const int side = kernel.Side();
  const int stride = kernel.Stride();
  const RiskMap& m = *map_;
  // Unknown ground: no sums (spec version 2). Locate never gives such a site.
  if (ci - hw < 0 || cj - hw < 0 || ci + hw >= m.nx() || cj + hw >= m.ny()) {
    RISKPLAN_DCHECK(false && "Ewmm of a window reaching past the map");
    *impact_factor = std::numeric_limits<double>::quiet_NaN();
    *expected_shelter = std::numeric_limits<double>::quiet_NaN();
    return;
  }
  // Rows are read `stride` cells wide: the columns past the kernel's side
  // have zero weights and fall on the layers' padding, which is finite. The
  // padding holds no data that is ever weighed.
  static_assert(RiskMap::kPad >= kKernelLanes - 1, "a row's zero-weight tail stays in the padding");
  const int64_t first = m.PaddedIndex(ci - hw, cj - hw);
  kEwmmRows(kernel.weights, side, stride, m.padded_density() + first, m.padded_shelter() + first,
            m.padded_nx(), impact_factor, expected_shelter);
}

bool RiskModel::Locate(const Pose& q, KernelSite* site) const {
  int i = 0;
  int j = 0;
  if (!std::isfinite(q.z) || !std::isfinite(q.theta) || !map_->CellOf(q.x, q.y, &i, &j)) {
    return false;
  }
  const double h = q.z - static_cast<double>(map_->terrain(i, j));
  if (!(h > 0.0)) return false;
  *site = SiteOf(*map_, *table_, AirHeadingBin(q.theta), q, h);
  return WindowInsideMap(*site);
}

ImpactReach RiskModel::Reach(double height_agl_m) const {
  const ImpactTable& t = *table_;
  ImpactReach r;
  r.height_bin = t.HeightBinOf(height_agl_m);
  r.west_m = r.east_m = r.south_m = r.north_m = -std::numeric_limits<double>::infinity();
  const double res = map_->res();
  for (int k = 0; k < t.heading_bins(); ++k) {
    const ImpactKernel& kernel = t.kernel(r.height_bin, k);
    const double window = kernel.half_width * res;
    r.west_m = std::max(r.west_m, window - kernel.offset_x_m);
    r.east_m = std::max(r.east_m, window + kernel.offset_x_m);
    r.south_m = std::max(r.south_m, window - kernel.offset_y_m);
    r.north_m = std::max(r.north_m, window + kernel.offset_y_m);
  }
  return r;
}

ConfigurationRisk RiskModel::FromSums(const KernelSite& site, double impact_factor,
                                      double expected_shelter) const {
  // Version 3: energy and exposed area per (height bin, air-heading bin); in
  // still air both are the height bin's own, bit for bit.
  const ImpactKernel& kernel = table_->kernel(site.height_bin, site.heading_bin);
  ConfigurationRisk out;
  out.impact_factor = impact_factor;
  out.expected_shelter = expected_shelter;
  out.casualty_probability =
      CasualtyProbability(kernel.energy_j, expected_shelter, params_.alpha_j, params_.beta_j);
  out.exposed_area_m2 = kernel.exposed_area_m2;
  out.risk = out.exposed_area_m2 * out.casualty_probability * impact_factor;
  out.height_bin = site.height_bin;
  out.heading_bin = site.heading_bin;
  out.defined = true;
  return out;
}

ConfigurationRisk RiskModel::Evaluate(const Pose& q) const {
  KernelSite site;
  if (!Locate(q, &site)) return ConfigurationRisk{};
  double impact_factor = 0.0;
  double shelter = 0.0;
  Ewmm(table_->kernel(site.height_bin, site.heading_bin), site.impact_i, site.impact_j,
       &impact_factor, &shelter);
  return FromSums(site, impact_factor, shelter);
}

size_t RiskModel::GlideBytes() const {
  return own_glide_ ? own_glide_->size() * sizeof(double) : 0;
}

size_t RiskModel::MemoryBytes() const {
  return table_->MemoryBytes() + (own_glide_ ? own_glide_->size() * sizeof(double) : 0) +
         air_bins_.capacity() * sizeof(int16_t);
}

}  // namespace riskplan
