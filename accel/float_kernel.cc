#include "accel/float_kernel.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

#include "core/base/check.h"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace riskplan::accel {
namespace {

// Widest kernel the loops are specialised for (8 blocks of 8 cells).
constexpr int kMaxBlocks = 8;

// Portable: float32 weights and cells, products and sums in double (a
// product of two floats is exact in double), eight lanes.
void FloatEwmmPortable(const FloatWindow* windows, int side, int weight_stride, int64_t map_stride,
                       double* impact_factor, double* expected_shelter) {
  const int cols = (side + 7) / 8 * 8;
  double acc_rho[8] = {};
  double acc_shelter[8] = {};
  const float* w = windows[0].weights;
  const float* r = windows[0].density;
  const float* s = windows[0].shelter;
  for (int v = 0; v < side; ++v) {
    for (int u = 0; u < cols; u += 8) {
      for (int l = 0; l < 8; ++l) {
        const double wd = static_cast<double>(w[u + l]);
        acc_rho[l] += wd * static_cast<double>(r[u + l]);
        acc_shelter[l] += wd * static_cast<double>(s[u + l]);
      }
    }
    w += weight_stride;
    r += map_stride;
    s += map_stride;
  }
  double i = 0.0;
  double sh = 0.0;
  for (int l = 0; l < 8; ++l) {
    i += acc_rho[l];
    sh += acc_shelter[l];
  }
  *impact_factor = i;
  *expected_shelter = sh;
}

#if defined(__x86_64__)
// GCC 12 warns about the undefined upper halves the AVX-512 conversions
// start from.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
// kN windows whose rows hold kBlocks blocks of 8 cells: kBlocks / 2 16-lane
// blocks and, when kBlocks is odd, one 8-lane block. Every lane sums at most
// kFlushRows products in float32 (fused multiply-add: one rounding per
// product and addition), then is added into a double lane.
template <int kBlocks, int kN, bool kShared>
__attribute__((target("avx512f,fma"))) void FloatEwmmAvx512(const FloatWindow* windows, int side,
                                                            int weight_stride, int64_t map_stride,
                                                            double* impact_factor,
                                                            double* expected_shelter) {
  constexpr int kZ = kBlocks / 2;
  constexpr bool kY = kBlocks % 2 == 1;
  constexpr int kZs = kZ > 0 ? kZ : 1;
  __m512d dr[kN], ds[kN];
  const float* w[kN];
  const float* r[kN];
  const float* s[kN];
#pragma GCC unroll 4
  for (int c = 0; c < kN; ++c) {
    dr[c] = ds[c] = _mm512_setzero_pd();
    w[c] = windows[c].weights;
    r[c] = windows[c].density;
    s[c] = windows[c].shelter;
  }
  for (int v0 = 0; v0 < side; v0 += kFlushRows) {
    const int v1 = std::min(side, v0 + kFlushRows);
    __m512 fr[kN][kZs], fs[kN][kZs];
    __m256 yr[kN], ys[kN];
#pragma GCC unroll 4
    for (int c = 0; c < kN; ++c) {
#pragma GCC unroll 4
      for (int b = 0; b < kZ; ++b) fr[c][b] = fs[c][b] = _mm512_setzero_ps();
      yr[c] = ys[c] = _mm256_setzero_ps();
    }
    for (int v = v0; v < v1; ++v) {
#pragma GCC unroll 4
      for (int b = 0; b < kZ; ++b) {
#pragma GCC unroll 4
        for (int c = 0; c < kN; ++c) {
          const __m512 wv = _mm512_load_ps((kShared ? w[0] : w[c]) + 16 * b);
          fr[c][b] = _mm512_fmadd_ps(wv, _mm512_loadu_ps(r[c] + 16 * b), fr[c][b]);
          fs[c][b] = _mm512_fmadd_ps(wv, _mm512_loadu_ps(s[c] + 16 * b), fs[c][b]);
        }
      }
      if constexpr (kY) {
#pragma GCC unroll 4
        for (int c = 0; c < kN; ++c) {
          const __m256 wv = _mm256_load_ps((kShared ? w[0] : w[c]) + 16 * kZ);
          yr[c] = _mm256_fmadd_ps(wv, _mm256_loadu_ps(r[c] + 16 * kZ), yr[c]);
          ys[c] = _mm256_fmadd_ps(wv, _mm256_loadu_ps(s[c] + 16 * kZ), ys[c]);
        }
      }
#pragma GCC unroll 4
      for (int c = 0; c < kN; ++c) {
        w[c] += weight_stride;
        r[c] += map_stride;
        s[c] += map_stride;
      }
    }
#pragma GCC unroll 4
    for (int c = 0; c < kN; ++c) {
#pragma GCC unroll 4
      for (int b = 0; b < kZ; ++b) {
        dr[c] = _mm512_add_pd(dr[c], _mm512_cvtps_pd(_mm512_castps512_ps256(fr[c][b])));
        dr[c] = _mm512_add_pd(dr[c], _mm512_cvtps_pd(_mm256_castpd_ps(
                                         _mm512_extractf64x4_pd(_mm512_castps_pd(fr[c][b]), 1))));
        ds[c] = _mm512_add_pd(ds[c], _mm512_cvtps_pd(_mm512_castps512_ps256(fs[c][b])));
        ds[c] = _mm512_add_pd(ds[c], _mm512_cvtps_pd(_mm256_castpd_ps(
                                         _mm512_extractf64x4_pd(_mm512_castps_pd(fs[c][b]), 1))));
      }
      if constexpr (kY) {
        dr[c] = _mm512_add_pd(dr[c], _mm512_cvtps_pd(yr[c]));
        ds[c] = _mm512_add_pd(ds[c], _mm512_cvtps_pd(ys[c]));
      }
    }
  }
#pragma GCC unroll 4
  for (int c = 0; c < kN; ++c) {
    impact_factor[c] = _mm512_reduce_add_pd(dr[c]);
    expected_shelter[c] = _mm512_reduce_add_pd(ds[c]);
  }
}

#pragma GCC diagnostic pop

// The same with 8-lane blocks.
template <int kBlocks, int kN, bool kShared>
__attribute__((target("avx2,fma"))) void FloatEwmmAvx2(const FloatWindow* windows, int side,
                                                       int weight_stride, int64_t map_stride,
                                                       double* impact_factor,
                                                       double* expected_shelter) {
  __m256d dr[kN], ds[kN];
  const float* w[kN];
  const float* r[kN];
  const float* s[kN];
#pragma GCC unroll 4
  for (int c = 0; c < kN; ++c) {
    dr[c] = ds[c] = _mm256_setzero_pd();
    w[c] = windows[c].weights;
    r[c] = windows[c].density;
    s[c] = windows[c].shelter;
  }
  for (int v0 = 0; v0 < side; v0 += kFlushRows) {
    const int v1 = std::min(side, v0 + kFlushRows);
    __m256 fr[kN][kBlocks], fs[kN][kBlocks];
#pragma GCC unroll 4
    for (int c = 0; c < kN; ++c) {
#pragma GCC unroll 8
      for (int b = 0; b < kBlocks; ++b) fr[c][b] = fs[c][b] = _mm256_setzero_ps();
    }
    for (int v = v0; v < v1; ++v) {
#pragma GCC unroll 8
      for (int b = 0; b < kBlocks; ++b) {
#pragma GCC unroll 4
        for (int c = 0; c < kN; ++c) {
          const __m256 wv = _mm256_load_ps((kShared ? w[0] : w[c]) + 8 * b);
          fr[c][b] = _mm256_fmadd_ps(wv, _mm256_loadu_ps(r[c] + 8 * b), fr[c][b]);
          fs[c][b] = _mm256_fmadd_ps(wv, _mm256_loadu_ps(s[c] + 8 * b), fs[c][b]);
        }
      }
#pragma GCC unroll 4
      for (int c = 0; c < kN; ++c) {
        w[c] += weight_stride;
        r[c] += map_stride;
        s[c] += map_stride;
      }
    }
#pragma GCC unroll 4
    for (int c = 0; c < kN; ++c) {
#pragma GCC unroll 8
      for (int b = 0; b < kBlocks; ++b) {
        dr[c] = _mm256_add_pd(dr[c], _mm256_cvtps_pd(_mm256_castps256_ps128(fr[c][b])));
        dr[c] = _mm256_add_pd(dr[c], _mm256_cvtps_pd(_mm256_extractf128_ps(fr[c][b], 1)));
        ds[c] = _mm256_add_pd(ds[c], _mm256_cvtps_pd(_mm256_castps256_ps128(fs[c][b])));
        ds[c] = _mm256_add_pd(ds[c], _mm256_cvtps_pd(_mm256_extractf128_ps(fs[c][b], 1)));
      }
    }
  }
#pragma GCC unroll 4
  for (int c = 0; c < kN; ++c) {
    alignas(32) double lanes[4];
    _mm256_store_pd(lanes, dr[c]);
    impact_factor[c] = (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
    _mm256_store_pd(lanes, ds[c]);
    expected_shelter[c] = (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
  }
}

template <int kN, bool kShared, int... kB>
constexpr std::array<FloatEwmmFn, sizeof...(kB)> Avx512Table(std::integer_sequence<int, kB...>) {
  return {&FloatEwmmAvx512<kB + 1, kN, kShared>...};
}
template <int kN, bool kShared, int... kB>
constexpr std::array<FloatEwmmFn, sizeof...(kB)> Avx2Table(std::integer_sequence<int, kB...>) {
  return {&FloatEwmmAvx2<kB + 1, kN, kShared>...};
}
#endif  // __x86_64__

}  // namespace

Isa FloatIsa(Isa isa) {
#if defined(__x86_64__)
  if (isa == Isa::kAvx2 && !__builtin_cpu_supports("fma")) return Isa::kPortable;
  return isa;
#else
  return Isa::kPortable;
#endif
}

int FloatGroupMax(Isa isa, int side) {
  const int blocks = (side + 7) / 8;
  // Enough windows in flight to hide the latency of the additions, few
  // enough that the accumulators stay in registers (32 with AVX-512, 16 with
  // AVX2).
  if (isa == Isa::kAvx512) return blocks <= 4 ? 4 : 2;
  if (isa == Isa::kAvx2) return blocks <= 2 ? 2 : 1;
  return 1;
}

FloatEwmmFn FloatLoopFor(Isa isa, int n, int side, bool shared) {
#if defined(__x86_64__)
  constexpr auto kBlocks = std::make_integer_sequence<int, kMaxBlocks>();
  static constexpr auto avx512_1 = Avx512Table<1, false>(kBlocks);
  static constexpr auto avx512_2 = Avx512Table<2, false>(kBlocks);
  static constexpr auto avx512_2s = Avx512Table<2, true>(kBlocks);
  static constexpr auto avx512_4 = Avx512Table<4, false>(kBlocks);
  static constexpr auto avx512_4s = Avx512Table<4, true>(kBlocks);
  static constexpr auto avx2_1 = Avx2Table<1, false>(kBlocks);
  static constexpr auto avx2_2 = Avx2Table<2, false>(kBlocks);
  static constexpr auto avx2_2s = Avx2Table<2, true>(kBlocks);
  const int b = (side + 7) / 8 - 1;
  if (isa == Isa::kAvx512) {
    if (n == 4) return shared ? avx512_4s[b] : avx512_4[b];
    if (n == 2) return shared ? avx512_2s[b] : avx512_2[b];
    return avx512_1[b];
  }
  if (isa == Isa::kAvx2) {
    if (n == 2) return shared ? avx2_2s[b] : avx2_2[b];
    return avx2_1[b];
  }
#endif
  return &FloatEwmmPortable;
}

void FastRiskFinisher::PrepareFor(const RiskModel& model) {
  const ModelParams& p = model.params();
  if (table_.lock() == model.table_ptr() && alpha_j_ == p.alpha_j && beta_j_ == p.beta_j) return;
  const ImpactTable& t = model.table();
  table_ = model.table_ptr();
  alpha_j_ = p.alpha_j;
  beta_j_ = p.beta_j;
  sqrt_alpha_over_beta_ = std::sqrt(p.alpha_j / p.beta_j);
  heading_bins_ = t.heading_bins();
  bins_.resize(static_cast<size_t>(t.height_bins()) * heading_bins_);
  for (int b = 1; b <= t.height_bins(); ++b) {
    for (int k = 0; k < heading_bins_; ++k) {
      const ImpactKernel& kernel = t.kernel(b, k);
      const double energy = kernel.energy_j;
      bins_[static_cast<size_t>(b - 1) * heading_bins_ + k] =
          Bin{kernel.exposed_area_m2, energy > p.beta_j ? 3.0 * std::log(p.beta_j / energy) : 0.0,
              energy > p.beta_j};
    }
  }
}

double FastRiskFinisher::CasualtyProbability(const KernelSite& site,
                                             double expected_shelter) const {
  const Bin& bin = BinOf(site);
  if (!bin.harmful) return 0.0;
  if (!(expected_shelter > 0.0)) return 1.0;
  // (beta/E)^(3/S~) = exp(3 ln(beta/E) / S~): below 1 since beta < E.
  const double e = std::exp(bin.three_log_ratio / expected_shelter);
  const double k = std::min(1.0, e);
  return (1.0 - k) / (1.0 - 2.0 * k + sqrt_alpha_over_beta_ * e);
}

ConfigurationRisk FastRiskFinisher::Finish(const KernelSite& site, double impact_factor,
                                           double expected_shelter) const {
  // PrepareFor(model) ran: the site's height bin has its constants.
  RISKPLAN_DCHECK(site.height_bin >= 1 && site.heading_bin >= 0 &&
                  static_cast<size_t>(site.height_bin - 1) * heading_bins_ + site.heading_bin <
                      bins_.size());
  ConfigurationRisk out;
  out.impact_factor = impact_factor;
  out.expected_shelter = expected_shelter;
  out.casualty_probability = CasualtyProbability(site, expected_shelter);
  out.exposed_area_m2 = BinOf(site).exposed_area_m2;
  out.risk = out.exposed_area_m2 * out.casualty_probability * impact_factor;
  out.height_bin = site.height_bin;
  out.heading_bin = site.heading_bin;
  out.defined = true;
  return out;
}

}  // namespace riskplan::accel
