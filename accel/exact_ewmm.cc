#include "accel/exact_ewmm.h"

#include <array>
#include <utility>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace riskplan::accel {
#if defined(__x86_64__)
namespace {

inline double ReduceLanes(const double* a) {
  return ((a[0] + a[1]) + (a[2] + a[3])) + ((a[4] + a[5]) + (a[6] + a[7]));
}

// The EWMM of kN windows of `rows` rows and kHalves four-lane column groups.
// RiskModel's lane l accumulates columns l, l+8, l+16, ... of every row, rows
// in order: here lanes 0-3 are the even halves (lo) and lanes 4-7 the odd
// ones (hi), added in the same order. Columns past the last half only hold
// zero weights; adding their +0 products to a non-negative sum changes
// nothing, so they are skipped.
template <int kHalves, int kN, bool kShared>
__attribute__((target("avx2"))) void EwmmAvx2(const ExactWindow* windows, int rows,
                                              int weight_stride, int64_t map_stride,
                                              double* impact_factor, double* expected_shelter) {
  __m256d rho_lo[kN], rho_hi[kN], sh_lo[kN], sh_hi[kN];
  const double* w[kN];
  const float* r[kN];
  const float* s[kN];
#pragma GCC unroll 4
  for (int c = 0; c < kN; ++c) {
    rho_lo[c] = rho_hi[c] = sh_lo[c] = sh_hi[c] = _mm256_setzero_pd();
    w[c] = windows[c].weights;
    r[c] = windows[c].density;
    s[c] = windows[c].shelter;
  }
  for (int v = 0; v < rows; ++v) {
#pragma GCC unroll 4
    for (int c = 0; c < kN; ++c) {
#pragma GCC unroll 16
      for (int h = 0; h < kHalves; ++h) {
        // With one kernel for all windows its weights are loaded once.
        const __m256d wv = _mm256_loadu_pd((kShared ? w[0] : w[c]) + 4 * h);
        const __m256d pr = _mm256_mul_pd(wv, _mm256_cvtps_pd(_mm_loadu_ps(r[c] + 4 * h)));
        const __m256d ps = _mm256_mul_pd(wv, _mm256_cvtps_pd(_mm_loadu_ps(s[c] + 4 * h)));
        if (h % 2 == 0) {
          rho_lo[c] = _mm256_add_pd(rho_lo[c], pr);
          sh_lo[c] = _mm256_add_pd(sh_lo[c], ps);
        } else {
          rho_hi[c] = _mm256_add_pd(rho_hi[c], pr);
          sh_hi[c] = _mm256_add_pd(sh_hi[c], ps);
        }
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
    alignas(32) double lanes[8];
    _mm256_store_pd(lanes, rho_lo[c]);
    _mm256_store_pd(lanes + 4, rho_hi[c]);
    impact_factor[c] = ReduceLanes(lanes);
    _mm256_store_pd(lanes, sh_lo[c]);
    _mm256_store_pd(lanes + 4, sh_hi[c]);
    expected_shelter[c] = ReduceLanes(lanes);
  }
}

// GCC 12 warns about the undefined upper half _mm512_cvtps_pd starts from.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
// The same sums with the eight lanes in one 512-bit register: block b of a
// row holds columns 8b .. 8b+7, so lane l again sees columns l, l+8, ... in
// order. Half the instructions of the AVX2 loop, and with 32 registers four
// windows stay in flight.
template <int kBlocks, int kN, bool kShared>
__attribute__((target("avx512f"))) void EwmmAvx512(const ExactWindow* windows, int rows,
                                                   int weight_stride, int64_t map_stride,
                                                   double* impact_factor,
                                                   double* expected_shelter) {
  __m512d rho[kN], sh[kN];
  const double* w[kN];
  const float* r[kN];
  const float* s[kN];
#pragma GCC unroll 4
  for (int c = 0; c < kN; ++c) {
    rho[c] = sh[c] = _mm512_setzero_pd();
    w[c] = windows[c].weights;
    r[c] = windows[c].density;
    s[c] = windows[c].shelter;
  }
  for (int v = 0; v < rows; ++v) {
#pragma GCC unroll 8
    for (int b = 0; b < kBlocks; ++b) {
#pragma GCC unroll 4
      for (int c = 0; c < kN; ++c) {
        const __m512d wv = _mm512_loadu_pd((kShared ? w[0] : w[c]) + 8 * b);
        rho[c] = _mm512_add_pd(rho[c],
                               _mm512_mul_pd(wv, _mm512_cvtps_pd(_mm256_loadu_ps(r[c] + 8 * b))));
        sh[c] =
            _mm512_add_pd(sh[c], _mm512_mul_pd(wv, _mm512_cvtps_pd(_mm256_loadu_ps(s[c] + 8 * b))));
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
    alignas(64) double lanes[8];
    _mm512_store_pd(lanes, rho[c]);
    impact_factor[c] = ReduceLanes(lanes);
    _mm512_store_pd(lanes, sh[c]);
    expected_shelter[c] = ReduceLanes(lanes);
  }
}

#pragma GCC diagnostic pop

template <int kN, bool kShared, int... kHalves>
constexpr std::array<ExactEwmmFn, sizeof...(kHalves)> Avx2Table(
    std::integer_sequence<int, kHalves...>) {
  return {&EwmmAvx2<kHalves + 1, kN, kShared>...};
}

template <int kN, bool kShared, int... kBlocks>
constexpr std::array<ExactEwmmFn, sizeof...(kBlocks)> Avx512Table(
    std::integer_sequence<int, kBlocks...>) {
  return {&EwmmAvx512<kBlocks + 1, kN, kShared>...};
}

}  // namespace

ExactEwmmFn ExactLoopFor(Isa isa, int n, int side, bool shared) {
  constexpr auto kHalves = std::make_integer_sequence<int, kMaxExactSide / 4>();
  constexpr auto kBlocks = std::make_integer_sequence<int, kMaxExactSide / 8>();
  static constexpr auto avx2_1 = Avx2Table<1, false>(kHalves);
  static constexpr auto avx2_2 = Avx2Table<2, false>(kHalves);
  static constexpr auto avx2_2s = Avx2Table<2, true>(kHalves);
  static constexpr auto avx512_1 = Avx512Table<1, false>(kBlocks);
  static constexpr auto avx512_2 = Avx512Table<2, false>(kBlocks);
  static constexpr auto avx512_2s = Avx512Table<2, true>(kBlocks);
  static constexpr auto avx512_4 = Avx512Table<4, false>(kBlocks);
  static constexpr auto avx512_4s = Avx512Table<4, true>(kBlocks);
  if (isa == Isa::kAvx512) {
    const int b = (side + 7) / 8 - 1;
    if (n == 4) return shared ? avx512_4s[b] : avx512_4[b];
    if (n == 2) return shared ? avx512_2s[b] : avx512_2[b];
    return avx512_1[b];
  }
  const int h = (side + 3) / 4 - 1;
  if (n >= 2) return shared ? avx2_2s[h] : avx2_2[h];
  return avx2_1[h];
}
#endif  // __x86_64__

}  // namespace riskplan::accel
