// The number format of the FPGA datapath: parsing, rounding, exponents, the
// exact accumulation, and the documented error bound against double.
#include "accel/fixed_point.h"

#include <cmath>
#include <vector>

#include "accel/blobs.h"
#include "core/base/random.h"
#include "gtest/gtest.h"

namespace riskplan::accel {
namespace {

TEST(NumberFormatTest, ParsesNamesAndPresets) {
  EXPECT_EQ(*NumberFormat::Parse("w32m32a80"), NumberFormat::Board());
  EXPECT_EQ(*NumberFormat::Parse("board"), NumberFormat::Board());
  EXPECT_EQ(*NumberFormat::Parse("precise"), NumberFormat::Precise());
  EXPECT_EQ(NumberFormat::Board().Name(), "w32m32a80");
  EXPECT_FALSE(NumberFormat::Parse("w32m32").ok());
  EXPECT_FALSE(NumberFormat::Parse("w32m32a70").ok());  // A < W + M + 12
  EXPECT_FALSE(NumberFormat::Parse("w60m32a128").ok());
  EXPECT_FALSE(NumberFormat::Parse("w32m32a80x").ok());
}

TEST(FixedPointTest, LayerExponentKeepsTheLargestValueWithinMBits) {
  for (double v : {1e-30, 2e-5, 0.05, 0.5, 1.0, 10.0, 1023.99, 3e20}) {
    const int e = LayerExponent(v, 32);
    EXPECT_LT(QuantizeCell(v, e), uint64_t{1} << 32) << v;
    EXPECT_GE(QuantizeCell(v, e), uint64_t{1} << 31) << v;  // uses the top bit
  }
  // Just below 2^k, rounding would reach 2^M: the exponent steps down.
  const double v = std::nextafter(1.0, 0.0);
  EXPECT_LT(QuantizeCell(v, LayerExponent(v, 32)), uint64_t{1} << 32);
  EXPECT_EQ(LayerExponent(0.0, 32), 32);
}

TEST(FixedPointTest, QuantisationRoundsToNearestAndSaturatesWeights) {
  EXPECT_EQ(QuantizeCell(0.5, 2), 2u);
  EXPECT_EQ(QuantizeCell(0.375, 2), 2u);  // 1.5 -> 2 (half up)
  EXPECT_EQ(QuantizeCell(0.3, 2), 1u);    // 1.2 -> 1
  EXPECT_EQ(QuantizeWeight(1.0, 32), (uint64_t{1} << 32) - 1);
  EXPECT_EQ(QuantizeWeight(0.0, 32), 0u);
  EXPECT_EQ(QuantizeWeight(0.25, 32), uint64_t{1} << 30);
}

TEST(FixedPointTest, AccumulatorWordsRoundTrip) {
  const Accumulator a = (Accumulator{0x0123456789abcdefULL} << 64) | 0xfedcba9876543210ULL;
  uint32_t words[4];
  AccumulatorToWords(a, words);
  EXPECT_EQ(words[0], 0x76543210u);
  EXPECT_EQ(words[3], 0x01234567u);
  EXPECT_TRUE(AccumulatorFromWords(words) == a);
}

// Random layers and kernels; the fixed-point sums against the sums in
// long double of the unquantised inputs, within the documented bound:
//   |I^ - I| <= 2^-W sum(rho) + 2^-(E+1) (1 + N 2^-W)   (+ one final rounding).
void CheckBound(const NumberFormat& format, uint64_t seed) {
  Rng rng(seed);
  const int nx = 50, ny = 40;
  std::vector<float> density(nx * ny), shelter(nx * ny);
  for (int c = 0; c < nx * ny; ++c) {
    density[c] =
        static_cast<float>(rng.Uniform() < 0.2 ? 0.08 * rng.Uniform() : 2e-5 * rng.Uniform());
    shelter[c] = static_cast<float>(10.0 * rng.Uniform());
  }
  const QuantizedMap q = QuantizeMap(nx, ny, density.data(), shelter.data(), format, 12);
  for (int trial = 0; trial < 300; ++trial) {
    const int hw = 1 + static_cast<int>(rng.Uniform() * 10);
    const int side = 2 * hw + 1;
    std::vector<double> w(side * side);
    double sum = 0.0;
    for (double& x : w) sum += (x = std::exp(-8.0 * rng.Uniform()));
    for (double& x : w) x /= sum;
    QuantizedKernel kernel;
    kernel.half_width = hw;
    for (double x : w) kernel.weights.push_back(QuantizeWeight(x, format.weight_frac_bits));
    const int ci = -5 + static_cast<int>(rng.Uniform() * (nx + 10));
    const int cj = -5 + static_cast<int>(rng.Uniform() * (ny + 10));
    Accumulator ai = 0, as = 0;
    ModelEwmm(q, kernel, ci, cj, &ai, &as);
    long double exact_i = 0, exact_s = 0, sum_rho = 0, sum_s = 0;
    for (int v = 0; v < side; ++v) {
      for (int u = 0; u < side; ++u) {
        const int i = ci - hw + u, j = cj - hw + v;
        const bool in = i >= 0 && j >= 0 && i < nx && j < ny;
        const double rho = in ? density[j * nx + i] : 0.0;
        const double s = in ? shelter[j * nx + i] : 10.0;
        exact_i += static_cast<long double>(w[v * side + u]) * rho;
        exact_s += static_cast<long double>(w[v * side + u]) * s;
        sum_rho += rho;
        sum_s += s;
      }
    }
    const double n = side * side;
    const double w_err = std::ldexp(1.0, -format.weight_frac_bits);
    const double bound_i = w_err * static_cast<double>(sum_rho) +
                           std::ldexp(1.0, -(q.density_exponent + 1)) * (1 + n * w_err) +
                           1e-15 * static_cast<double>(exact_i);
    const double bound_s = w_err * static_cast<double>(sum_s) +
                           std::ldexp(1.0, -(q.shelter_exponent + 1)) * (1 + n * w_err) +
                           1e-15 * static_cast<double>(exact_s);
    const double got_i = AccumulatorToDouble(ai, format.weight_frac_bits + q.density_exponent);
    const double got_s = AccumulatorToDouble(as, format.weight_frac_bits + q.shelter_exponent);
    EXPECT_LE(std::abs(got_i - static_cast<double>(exact_i)), bound_i) << format.Name();
    EXPECT_LE(std::abs(got_s - static_cast<double>(exact_s)), bound_s) << format.Name();
  }
}

TEST(FixedPointTest, ErrorWithinTheDocumentedBoundBoard) { CheckBound(NumberFormat::Board(), 1); }
TEST(FixedPointTest, ErrorWithinTheDocumentedBoundPrecise) {
  CheckBound(NumberFormat::Precise(), 2);
}
TEST(FixedPointTest, ErrorWithinTheDocumentedBoundNarrow) {
  CheckBound(*NumberFormat::Parse("w16m16a44"), 3);
}

TEST(FixedPointTest, SumsDoNotDependOnTheOrderOfAccumulation) {
  // Every product and sum is exact: adding in reverse gives the same bits.
  Rng rng(7);
  const NumberFormat f = NumberFormat::Board();
  std::vector<uint64_t> w(441), c(441);
  Accumulator forward = 0, backward = 0;
  for (int k = 0; k < 441; ++k) {
    w[k] = QuantizeWeight(rng.Uniform() / 441, f.weight_frac_bits);
    c[k] = QuantizeCell(rng.Uniform(), 32);
  }
  for (int k = 0; k < 441; ++k) forward += static_cast<Accumulator>(w[k]) * c[k];
  for (int k = 440; k >= 0; --k) backward += static_cast<Accumulator>(w[k]) * c[k];
  EXPECT_TRUE(forward == backward);
  EXPECT_TRUE(forward >> f.acc_bits == 0);
}

}  // namespace
}  // namespace riskplan::accel
