#include "core/map/demo_city.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/check.h"
#include "core/base/geometry.h"

// Layout. Everything is placed in *design* coordinates: metres on the default
// 8 km map, origin at its south-west corner. A map of another size is the same
// city scaled by size_m / 8000, so the landmarks below keep their relative
// places (tests build a 2 km version). Landmarks are fixed; the seed moves only
// noise, park and field positions, so that tests and examples can rely on the
// landmark coordinates for every seed.
//
// Determinism: only +, -, *, /, sqrt, floor and ceil are used on floating
// point (all exactly rounded by IEEE 754), and random numbers come from our own
// splitmix64, so the map is the same bit for bit with any compiler and libm
// (core/CMakeLists.txt compiles this file with -ffp-contract=off, so that no
// compiler fuses a multiply and an add into one differently rounded FMA).

namespace riskplan {
namespace {

constexpr double kDesignSize = 8000.0;
constexpr double kCentreX = 4000.0, kCentreY = 4000.0;

struct Rect {
  double x0, y0, x1, y1;  // design metres, [x0, x1) x [y0, y1)
  bool Contains(double x, double y) const { return x >= x0 && x < x1 && y >= y0 && y < y1; }
  bool Overlaps(const Rect& o, double margin) const {
    return x0 - margin < o.x1 && o.x0 < x1 + margin && y0 - margin < o.y1 && o.y0 < y1 + margin;
  }
};

// No-fly zones and other fixed landmarks (GetDemoCityLandmarks() publishes them).
constexpr Rect kAirport = {5400, 1500, 6600, 2100};
constexpr Rect kRunway = {5500, 1780, 6500, 1825};
constexpr Rect kTerminal = {5700, 1950, 6100, 2100};
constexpr Rect kHospital = {4300, 4200, 4450, 4350};
constexpr Rect kStadium = {2500, 3600, 2800, 3850};
constexpr Rect kNoFly[] = {kAirport, kHospital, kStadium};
constexpr Rect kIndustrial[] = {{5300, 2600, 6700, 3600}, {1500, 1100, 2300, 1700}};
constexpr Rect kCentralPark = {3250, 4450, 3750, 4750};
struct Route {
  const char* name;
  double x0, y0, x1, y1;
};
constexpr Route kRoutes[3] = {{"west-east", 1560, 3940, 6440, 4060},
                              {"southwest-northeast", 1440, 3060, 6560, 4940},
                              {"south-north", 3810, 1190, 4190, 6810}};

uint64_t SplitMix64(uint64_t& state) {
  uint64_t z = (state += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

// Uniform in [0, 1) from the top 53 bits.
double Uniform(uint64_t& state) { return static_cast<double>(SplitMix64(state) >> 11) * 0x1.0p-53; }

double Clamp01(double t) { return t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t); }
double SmoothStep(double t) {
  t = Clamp01(t);
  return t * t * (3.0 - 2.0 * t);
}
double Lerp(double a, double b, double t) { return a + (b - a) * t; }

// 2-D value noise in [0, 1]: random values on a square lattice of spacing
// `spacing` (design metres), smoothstep-interpolated between lattice points.
class ValueNoise {
 public:
  ValueNoise(uint64_t seed, uint64_t salt, double spacing)
      : inv_spacing_(1.0 / spacing), n_(static_cast<int>(std::ceil(kDesignSize / spacing)) + 2) {
    uint64_t state = seed ^ (salt * 0xd1b54a32d192ed03ull);
    values_.resize(static_cast<size_t>(n_) * n_);
    for (double& v : values_) v = Uniform(state);
  }

  // REQUIRES: 0 <= x, y <= kDesignSize.
  double operator()(double x, double y) const {
    RISKPLAN_DCHECK(x >= 0.0 && y >= 0.0 && x <= kDesignSize && y <= kDesignSize);
    const double fx = x * inv_spacing_, fy = y * inv_spacing_;
    const double flx = std::floor(fx), fly = std::floor(fy);
    const int ix = std::min(static_cast<int>(flx), n_ - 2);
    const int iy = std::min(static_cast<int>(fly), n_ - 2);
    const double tx = SmoothStep(fx - flx), ty = SmoothStep(fy - fly);
    const double* row0 = &values_[static_cast<size_t>(iy) * n_ + ix];
    const double* row1 = row0 + n_;
    return Lerp(Lerp(row0[0], row0[1], tx), Lerp(row1[0], row1[1], tx), ty);
  }

 private:
  double inv_spacing_;
  int n_;
  std::vector<double> values_;
};

// A polynomial bump: 1 at the centre, 0 from `radius` on, smooth everywhere.
double Bump(double x, double y, double cx, double cy, double radius) {
  const double d2 = ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / (radius * radius);
  return d2 >= 1.0 ? 0.0 : (1.0 - d2) * (1.0 - d2);
}

// Distance from v to the nearest multiple of `spacing`.
double GridDistance(double v, double spacing) {
  return std::abs(v - spacing * std::floor(v / spacing + 0.5));
}

// Cells whose centres lie in [lo, hi) (design metres) along one axis: [*a, *b).
void CellSpan(double lo, double hi, double cell, int n, int* a, int* b) {
  *a = std::clamp(static_cast<int>(std::ceil(lo / cell - 0.5)), 0, n);
  *b = std::clamp(static_cast<int>(std::ceil(hi / cell - 0.5)), 0, n);
}

struct Park {
  Rect rect;
  std::string name;
};

// Open areas that double as landing sites: one per square kilometre (design)
// on a jittered 8 x 8 grid, a park inside the city and a field outside it,
// kept clear of no-fly zones, plus the central park.
std::vector<Park> PlaceParks(uint64_t seed, double urban_radius) {
  std::vector<Park> parks;
  uint64_t state = seed ^ 0x5eedf1e1d5ull;
  int park_count = 0, field_count = 0;
  for (int b = 0; b < 8; ++b) {
    for (int a = 0; a < 8; ++a) {
      for (int attempt = 0; attempt < 32; ++attempt) {
        const double cx = 500.0 + 1000.0 * a + 500.0 * (Uniform(state) - 0.5);
        const double cy = 500.0 + 1000.0 * b + 500.0 * (Uniform(state) - 0.5);
        const double r =
            std::sqrt((cx - kCentreX) * (cx - kCentreX) + (cy - kCentreY) * (cy - kCentreY));
        const bool urban = r < urban_radius;
        const double hx = (urban ? 50.0 : 90.0) + 70.0 * Uniform(state);
        const double hy = (urban ? 50.0 : 90.0) + 70.0 * Uniform(state);
        const Rect rect = {std::max(cx - hx, 10.0), std::max(cy - hy, 10.0),
                           std::min(cx + hx, kDesignSize - 10.0),
                           std::min(cy + hy, kDesignSize - 10.0)};
        bool clear = true;
        for (const Rect& z : kNoFly) clear = clear && !rect.Overlaps(z, 60.0);
        if (!clear) continue;
        parks.push_back({rect, urban ? absl::StrCat("park-", ++park_count)
                                     : absl::StrCat("field-", ++field_count)});
        break;
      }
    }
  }
  parks.push_back({kCentralPark, "central-park"});
  return parks;
}

}  // namespace

absl::StatusOr<std::shared_ptr<const RiskMap>> MakeDemoCity(const DemoCityOptions& options,
                                                            const ModelParams& params) {
  if (!(std::isfinite(options.size_m) && options.size_m > 0.0 && std::isfinite(options.res_m) &&
        options.res_m > 0.0 && options.size_m / options.res_m <= kMaxMapSide)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "demo-city: size_m %.17g and res_m %.17g must be finite, > 0 and give at most %d cells "
        "per side",
        options.size_m, options.res_m, kMaxMapSide));
  }
  const int n = std::max(1, static_cast<int>(std::floor(options.size_m / options.res_m + 0.5)));
  // Checked before the layers are allocated, not left to RiskMap::Create().
  if (static_cast<int64_t>(n) * n > kMaxMapCells) {
    return absl::InvalidArgumentError(
        absl::StrFormat("demo-city: size_m %.17g and res_m %.17g give %d x %d cells, more than %d",
                        options.size_m, options.res_m, n, n, kMaxMapCells));
  }
  // Design metres per cell: the city is drawn at design scale and sampled at
  // each cell centre.
  const double scale = options.size_m / kDesignSize;
  const double cell = options.res_m / scale;
  const uint64_t seed = options.seed;

  MapHeader header;
  header.name = "demo-city";
  header.res = options.res_m;
  header.nx = n;
  header.ny = n;
  header.provenance =
      absl::StrFormat("riskplan demo-city generator v1, seed %d, %.17g m at %.17g m cells", seed,
                      options.size_m, options.res_m);

  const ValueNoise urban_edge(seed, 1, 1500.0);  // ragged city limit
  const ValueNoise texture(seed, 2, 150.0);      // block-to-block density variation
  const ValueNoise building(seed, 3, 60.0);      // block-to-block shelter variation
  const ValueNoise woods(seed, 4, 600.0);        // woods vs farmland outside the city
  const ValueNoise relief1(seed, 5, 2000.0);
  const ValueNoise relief2(seed, 6, 700.0);
  const ValueNoise relief3(seed, 7, 250.0);
  const ValueNoise hill_shape(seed, 8, 900.0);

  // Street widths never drop below one cell; minor streets are left out when
  // the map is too coarse to show them as streets rather than as a mesh.
  const double arterial_half = std::max(10.0, 0.5 * cell);
  const double street_half = std::max(5.0, 0.5 * cell);
  const bool draw_streets = 125.0 >= 4.0 * cell;

  const size_t cells = static_cast<size_t>(n) * n;
  MapLayers layers;
  layers.density.resize(cells);
  layers.shelter.resize(cells);
  layers.terrain.resize(cells);
  layers.nofly.assign(cells, 0);

  for (int j = 0; j < n; ++j) {
    const double y = (j + 0.5) * cell;
    for (int i = 0; i < n; ++i) {
      const double x = (i + 0.5) * cell;
      const size_t k = static_cast<size_t>(j) * n + i;
      const double dx = x - kCentreX, dy = y - kCentreY;
      const double r2 = dx * dx + dy * dy;
      const double r = std::sqrt(r2);
      const double tex = texture(x, y);
      const double bld = building(x, y);

      // Downtown weight: 1 at the centre, 1/4 at 700 m, about 0.005 at 2.5 km.
      const double core = 1.0 / ((1.0 + r2 / (700.0 * 700.0)) * (1.0 + r2 / (700.0 * 700.0)));
      const double urban_radius = 3000.0 + 1200.0 * (urban_edge(x, y) - 0.5);
      const double urbanity = SmoothStep((urban_radius - r) / 200.0);

      double density_city = (0.046 * core + 0.0035) * (0.7 + 0.6 * tex);
      const double blend = Clamp01(2.0 * core);
      double shelter_city = Lerp(4.0 + 3.0 * bld, 6.0 + 3.0 * bld, blend);
      double density_rural, shelter_rural;
      if (woods(x, y) > 0.66) {
        density_rural = 0.00002;
        shelter_rural = 3.0 + 2.0 * bld;
      } else {
        density_rural = 0.0001 + 0.0002 * tex;
        shelter_rural = 0.2 + 0.7 * bld;
      }
      for (const Rect& z : kIndustrial) {
        if (z.Contains(x, y)) {
          density_city = density_rural = 0.0006 + 0.0006 * tex;
          shelter_city = shelter_rural = 8.0 + 2.0 * bld;
        }
      }
      const bool arterial =
          GridDistance(x, 500.0) < arterial_half || GridDistance(y, 500.0) < arterial_half;
      const bool street =
          draw_streets && urbanity > 0.5 &&
          (GridDistance(x, 125.0) < street_half || GridDistance(y, 125.0) < street_half);
      if (arterial || street) {
        // People on pavements and in vehicles, next to no cover.
        density_city = 0.3 * density_city + 0.001;
        shelter_city = 1.0 + bld;
        if (arterial) {
          density_rural = 0.0003;
          shelter_rural = 1.0;
        }
      }
      layers.density[k] = static_cast<float>(Lerp(density_rural, density_city, urbanity));
      layers.shelter[k] = static_cast<float>(Lerp(shelter_rural, shelter_city, urbanity));

      // Terrain: a gently rolling basin (about 100-140 m) with a high range to
      // the north-west (up to about 280 m) and a lower hill to the north-east.
      double t = 100.0 + 26.0 * relief1(x, y) + 10.0 * relief2(x, y) + 4.0 * relief3(x, y);
      t += 165.0 * (0.75 + 0.5 * hill_shape(x, y)) * Bump(x, y, 1200.0, 6900.0, 2700.0);
      t += 85.0 * (0.75 + 0.5 * hill_shape(x, y)) * Bump(x, y, 7000.0, 6900.0, 1500.0);
      // The airfield is levelled; the levelling fades out over 300 m around it.
      const double ax = std::max({kAirport.x0 - x, x - kAirport.x1, 0.0});
      const double ay = std::max({kAirport.y0 - y, y - kAirport.y1, 0.0});
      t = Lerp(112.0, t, SmoothStep(std::max(ax, ay) / 300.0));
      layers.terrain[k] = static_cast<float>(t);
    }
  }

  // Rectangular features are drawn over the base layers by cell span, cheaper
  // than testing every cell against every feature.
  auto fill = [&](const Rect& rect, auto&& paint) {
    int i0, i1, j0, j1;
    CellSpan(rect.x0, rect.x1, cell, n, &i0, &i1);
    CellSpan(rect.y0, rect.y1, cell, n, &j0, &j1);
    for (int j = j0; j < j1; ++j) {
      for (int i = i0; i < i1; ++i)
        paint(static_cast<size_t>(j) * n + i, (i + 0.5) * cell, (j + 0.5) * cell);
    }
  };

  // Landing sites at the centre of each park; a site's cell must be open
  // ground even when the park is smaller than a cell.
  const std::vector<Park> parks = PlaceParks(seed, 3000.0);
  for (const Park& park : parks) {
    const bool field = park.name.rfind("field-", 0) == 0;
    Rect rect = park.rect;
    const double cx = 0.5 * (rect.x0 + rect.x1), cy = 0.5 * (rect.y0 + rect.y1);
    rect.x0 = std::min(rect.x0, cx - 0.5 * cell);
    rect.x1 = std::max(rect.x1, cx + 0.5 * cell);
    rect.y0 = std::min(rect.y0, cy - 0.5 * cell);
    rect.y1 = std::max(rect.y1, cy + 0.5 * cell);
    fill(rect, [&](size_t k, double x, double y) {
      layers.density[k] = static_cast<float>(field ? 0.00003 : 0.0002 + 0.0003 * texture(x, y));
      layers.shelter[k] =
          static_cast<float>(field ? 0.1 + 0.3 * building(x, y) : 0.3 + 0.7 * building(x, y));
    });
    const int si = ClampedCell(cx, cell, n);
    const int sj = ClampedCell(cy, cell, n);
    layers.landing_sites.push_back({park.name, si, sj});
  }

  // No-fly zones, with ground that still matters to impacts landing in them.
  fill(kAirport, [&](size_t k, double x, double y) {
    layers.nofly[k] = 1;
    if (kRunway.Contains(x, y)) {
      layers.density[k] = 0.0f;
      layers.shelter[k] = 0.0f;
    } else if (kTerminal.Contains(x, y)) {
      layers.density[k] = 0.004f;
      layers.shelter[k] = 6.0f;
    } else {
      layers.density[k] = 0.0001f;
      layers.shelter[k] = 0.3f;
    }
  });
  fill(kHospital, [&](size_t k, double, double) {
    layers.nofly[k] = 1;
    layers.density[k] = 0.012f;
    layers.shelter[k] = 7.0f;
  });
  fill(kStadium, [&](size_t k, double, double) {
    layers.nofly[k] = 1;
    layers.density[k] = 0.02f;
    layers.shelter[k] = 3.0f;
  });

  return RiskMap::Create(std::move(header), std::move(layers), params.glide_ratio,
                         params.glide_clearance_m);
}

DemoCityLandmarks GetDemoCityLandmarks(const DemoCityOptions& options) {
  const double k = options.size_m / kDesignSize;
  auto box = [k](const Rect& r) { return DemoCityBox{r.x0 * k, r.y0 * k, r.x1 * k, r.y1 * k}; };
  DemoCityLandmarks out;
  out.centre = {kCentreX * k, kCentreY * k};
  out.airport = box(kAirport);
  out.runway = box(kRunway);
  out.hospital = box(kHospital);
  out.stadium = box(kStadium);
  out.industrial[0] = box(kIndustrial[0]);
  out.industrial[1] = box(kIndustrial[1]);
  out.central_park = box(kCentralPark);
  for (int r = 0; r < 3; ++r) {
    const Route& route = kRoutes[r];
    out.routes[r] = {route.name, {route.x0 * k, route.y0 * k}, {route.x1 * k, route.y1 * k}};
  }
  return out;
}

}  // namespace riskplan
