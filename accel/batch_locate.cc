#include "accel/batch_locate.h"

#include <algorithm>
#include <cmath>

#include "core/base/check.h"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace riskplan::accel {
namespace {

// The per-model constants of RiskModel::Locate.
struct LocateConstants {
  double x0, y0, res;
  double nx, ny;
  int nx_int;
  const float* terrain;
  double height_bin_m;
  int height_bins;
  double heading_bin_width;
  int heading_bins;
};

LocateConstants ConstantsOf(const RiskModel& model) {
  const RiskMap& m = model.map();
  const ImpactTable& t = model.table();
  LocateConstants c;
  c.x0 = m.x0();
  c.y0 = m.y0();
  c.res = m.res();
  c.nx = m.nx();
  c.ny = m.ny();
  c.nx_int = m.nx();
  c.terrain = m.layers().terrain.data();
  c.height_bin_m = t.params().height_bin_m;
  c.height_bins = t.height_bins();
  // The same expression as ImpactTable::HeadingBinOf, hence the same double.
  c.heading_bin_width = kTwoPi / t.heading_bins();
  c.heading_bins = t.heading_bins();
  return c;
}

void LocatePortable(const RiskModel& model, std::span<const Pose> configs,
                    std::span<ConfigurationRisk> out, std::vector<LocatedSite>* sites) {
  for (size_t n = 0; n < configs.size(); ++n) {
    LocatedSite s;
    s.index = static_cast<uint32_t>(n);
    if (model.Locate(configs[n], &s.site)) {
      sites->push_back(s);
    } else {
      out[n] = ConfigurationRisk{};
    }
  }
}

#if defined(__x86_64__)
// Configurations per block of LocateAvx2.
constexpr size_t kLocateBlock = 64;

// RiskModel::Locate for a batch, operation for operation (this file is built
// with -ffp-contract=off like core/), in passes over blocks of 64
// configurations: the divisions and floors four configurations at a time
// (vdivpd and vroundpd round like divsd and floor), the table look-ups one
// by one, the terrain cells prefetched a pass before they are read (at
// random positions, and along diagonal legs, the terrain read misses). fmod of an integral heading
// bin by N is the integer remainder (same sign as the dividend) while the quotient fits in 31 bits,
// else the library's.
__attribute__((target("avx2"))) void LocateAvx2(const RiskModel& model,
                                                std::span<const Pose> configs,
                                                std::span<ConfigurationRisk> out,
                                                std::vector<LocatedSite>* sites) {
  static_assert(sizeof(Pose) == 4 * sizeof(double), "Pose is x, y, z, theta");
  const LocateConstants c = ConstantsOf(model);
  const ImpactTable& table = model.table();
  const size_t n = configs.size();
  const size_t first_site = sites->size();
  sites->resize(first_site + n);  // cut to the defined ones at the end
  LocatedSite* next = sites->data() + first_site;
  alignas(32) double xs[kLocateBlock];
  alignas(32) double ys[kLocateBlock];
  alignas(32) double fx[kLocateBlock];
  alignas(32) double fy[kLocateBlock];
  alignas(32) double kf[kLocateBlock];
  // In a wind, the heading bin of each configuration's air heading (spec
  // version 3), RiskModel::AirHeadingBin's; in still air pass 1 computes it.
  int air_bin[kLocateBlock];
  const bool calm = model.wind().calm();
  alignas(32) double h[kLocateBlock];
  alignas(32) double bf[kLocateBlock];
  alignas(32) double ox[kLocateBlock];
  alignas(32) double oy[kLocateBlock];
  alignas(32) double ci[kLocateBlock];
  alignas(32) double cj[kLocateBlock];
  bool defined[kLocateBlock];
  int half_width[kLocateBlock];
  KernelSite site[kLocateBlock];
  const __m256d x0 = _mm256_set1_pd(c.x0);
  const __m256d y0 = _mm256_set1_pd(c.y0);
  const __m256d res = _mm256_set1_pd(c.res);
  const __m256d width = _mm256_set1_pd(c.heading_bin_width);
  const __m256d bin_m = _mm256_set1_pd(c.height_bin_m);
  const __m256d half = _mm256_set1_pd(0.5);
  const __m256d zero = _mm256_setzero_pd();
  const __m256d last_i = _mm256_set1_pd(c.nx - 1.0);
  const __m256d last_j = _mm256_set1_pd(c.ny - 1.0);
  constexpr int kFloor = _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC;
  for (size_t base = 0; base < n; base += kLocateBlock) {
    const size_t m = std::min(kLocateBlock, n - base);
    const size_t m4 = (m + 3) / 4 * 4;  // lanes past m hold copies of the last pose
    // Pass 0, in wind: the bin of the air heading of each track heading,
    // which picks the kernel (RiskModel::Locate's SiteOf), mostly from the
    // model's table. A heading that is not finite is never located (pass 2).
    if (!calm) {
      for (size_t t = 0; t < m4; ++t) {
        const double theta = configs[base + std::min(t, m - 1)].theta;
        air_bin[t] = std::isfinite(theta) ? model.AirHeadingBin(theta) : 0;
      }
    }
    // Pass 1: x, y and the floors of the cell and of the heading bin.
    for (size_t t = 0; t < m4; t += 4) {
      const auto pose = [&](size_t u) { return &configs[base + std::min(u, m - 1)].x; };
      const __m256d r0 = _mm256_loadu_pd(pose(t));
      const __m256d r1 = _mm256_loadu_pd(pose(t + 1));
      const __m256d r2 = _mm256_loadu_pd(pose(t + 2));
      const __m256d r3 = _mm256_loadu_pd(pose(t + 3));
      const __m256d t0 = _mm256_unpacklo_pd(r0, r1);  // x0 x1 z0 z1
      const __m256d t1 = _mm256_unpackhi_pd(r0, r1);  // y0 y1 theta0 theta1
      const __m256d t2 = _mm256_unpacklo_pd(r2, r3);
      const __m256d t3 = _mm256_unpackhi_pd(r2, r3);
      const __m256d x = _mm256_permute2f128_pd(t0, t2, 0x20);
      const __m256d y = _mm256_permute2f128_pd(t1, t3, 0x20);
      const __m256d theta = _mm256_permute2f128_pd(t1, t3, 0x31);
      _mm256_store_pd(xs + t, x);
      _mm256_store_pd(ys + t, y);
      _mm256_store_pd(fx + t, _mm256_round_pd(_mm256_div_pd(_mm256_sub_pd(x, x0), res), kFloor));
      _mm256_store_pd(fy + t, _mm256_round_pd(_mm256_div_pd(_mm256_sub_pd(y, y0), res), kFloor));
      _mm256_store_pd(kf + t,
                      _mm256_round_pd(_mm256_add_pd(_mm256_div_pd(theta, width), half), kFloor));
      // The terrain cells, a pass ahead of their reads (clamped into the
      // map: a prefetch of a cell outside it is wasted, never wrong).
      alignas(16) int32_t cell_i[4];
      alignas(16) int32_t cell_j[4];
      _mm_store_si128(
          reinterpret_cast<__m128i*>(cell_i),
          _mm256_cvttpd_epi32(_mm256_min_pd(_mm256_max_pd(_mm256_load_pd(fx + t), zero), last_i)));
      _mm_store_si128(
          reinterpret_cast<__m128i*>(cell_j),
          _mm256_cvttpd_epi32(_mm256_min_pd(_mm256_max_pd(_mm256_load_pd(fy + t), zero), last_j)));
      for (int l = 0; l < 4; ++l) {
        _mm_prefetch(
            reinterpret_cast<const char*>(c.terrain + int64_t{cell_j[l]} * c.nx_int + cell_i[l]),
            _MM_HINT_T0);
      }
    }
    // Pass 2: inside the map, the terrain, h.
    for (size_t t = 0; t < m4; ++t) {
      const Pose& q = configs[base + std::min(t, m - 1)];
      h[t] = 0.0;
      defined[t] = std::isfinite(q.z) && std::isfinite(q.theta) && fx[t] >= 0.0 && fx[t] < c.nx &&
                   fy[t] >= 0.0 && fy[t] < c.ny;
      if (!defined[t]) continue;
      const int i = static_cast<int>(fx[t]);
      const int j = static_cast<int>(fy[t]);
      h[t] = q.z - static_cast<double>(c.terrain[static_cast<int64_t>(j) * c.nx_int + i]);
      defined[t] = h[t] > 0.0;
    }
    // Pass 3: the floor of the height bin.
    for (size_t t = 0; t < m4; t += 4) {
      const __m256d hv = _mm256_load_pd(h + t);
      _mm256_store_pd(bf + t,
                      _mm256_round_pd(_mm256_add_pd(_mm256_div_pd(hv, bin_m), half), kFloor));
    }
    // Pass 4: the bins and the kernel's offset.
    for (size_t t = 0; t < m4; ++t) {
      ox[t] = oy[t] = 0.0;
      if (!defined[t]) continue;
      int b;
      if (!(bf[t] >= 1.0)) {
        b = 1;
      } else if (bf[t] > c.height_bins) {
        b = c.height_bins;
      } else {
        b = static_cast<int>(bf[t]);
      }
      int k;
      if (!calm) {
        k = air_bin[t];
      } else if (kf[t] >= 0.0 && kf[t] < c.heading_bins) {
        k = static_cast<int>(kf[t]);  // theta in [0, 2 pi): no division
      } else if (kf[t] > -2147483648.0 && kf[t] < 2147483648.0) {
        const int r = static_cast<int>(kf[t]) % c.heading_bins;
        k = r < 0 ? r + c.heading_bins : r;
      } else {
        k = table.HeadingBinOf(configs[base + t].theta);
      }
      const ImpactKernel& kernel = table.kernel(b, k);
      site[t].height_bin = b;
      site[t].heading_bin = k;
      half_width[t] = kernel.half_width;
      ox[t] = kernel.offset_x_m;
      oy[t] = kernel.offset_y_m;
    }
    // Pass 5: the impact cell.
    for (size_t t = 0; t < m4; t += 4) {
      const __m256d x = _mm256_add_pd(_mm256_load_pd(xs + t), _mm256_load_pd(ox + t));
      const __m256d y = _mm256_add_pd(_mm256_load_pd(ys + t), _mm256_load_pd(oy + t));
      _mm256_store_pd(ci + t, _mm256_round_pd(_mm256_div_pd(_mm256_sub_pd(x, x0), res), kFloor));
      _mm256_store_pd(cj + t, _mm256_round_pd(_mm256_div_pd(_mm256_sub_pd(y, y0), res), kFloor));
    }
    // The window rule of spec version 2 (RiskModel::WindowInsideMap): a
    // window reaching past the map leaves M undefined. The impact cells are
    // integral doubles, compared as doubles so that none is converted out of
    // int's range.
    for (size_t t = 0; t < m; ++t) {
      if (defined[t]) {
        const double hw = half_width[t];
        defined[t] = ci[t] >= hw && cj[t] >= hw && ci[t] < c.nx - hw && cj[t] < c.ny - hw;
      }
      if (!defined[t]) {
        out[base + t] = ConfigurationRisk{};
        continue;
      }
      next->index = static_cast<uint32_t>(base + t);
      next->site = site[t];
      next->site.impact_i = static_cast<int>(ci[t]);
      next->site.impact_j = static_cast<int>(cj[t]);
      ++next;
    }
  }
  sites->resize(static_cast<size_t>(next - sites->data()));
}

#endif  // __x86_64__

}  // namespace

void LocateSites(const RiskModel& model, std::span<const Pose> configs,
                 std::span<ConfigurationRisk> out, std::vector<LocatedSite>* sites, bool use_avx2) {
  RISKPLAN_DCHECK(out.size() == configs.size() && configs.size() <= (size_t{1} << 32));
#if defined(__x86_64__)
  if (use_avx2) return LocateAvx2(model, configs, out, sites);
#endif
  LocatePortable(model, configs, out, sites);
}

}  // namespace riskplan::accel
