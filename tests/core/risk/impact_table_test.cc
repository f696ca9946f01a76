#include "core/risk/impact_table.h"

#include <cmath>
#include <string>

#include "absl/strings/str_format.h"
#include "core/base/geometry.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace riskplan {
namespace {

TEST(ImpactTableTest, EveryKernelSumsToOne) {
  ModelParams p;
  auto table = ImpactTable::Build(p, 5.0);
  ASSERT_TRUE(table.ok()) << table.status();
  ASSERT_EQ((*table)->height_bins(), 60);
  ASSERT_EQ((*table)->heading_bins(), 72);
  for (int b = 1; b <= (*table)->height_bins(); ++b) {
    for (int k = 0; k < (*table)->heading_bins(); ++k) {
      const ImpactKernel& kernel = (*table)->kernel(b, k);
      double sum = 0.0;
      for (int v = 0; v < kernel.Side(); ++v) {
        for (int u = 0; u < kernel.Stride(); ++u) {
          const double w = kernel.weights[v * kernel.Stride() + u];
          if (u >= kernel.Side()) {
            ASSERT_EQ(w, 0.0);  // row padding
          } else {
            ASSERT_GE(w, 0.0);
          }
          sum += w;
        }
      }
      EXPECT_NEAR(sum, 1.0, 1e-12) << "b=" << b << " k=" << k;
    }
  }
}

TEST(ImpactTableTest, HalfWidthFollowsSigmaAndIsCapped) {
  ModelParams p;
  auto table = ImpactTable::Build(p, 5.0);
  ASSERT_TRUE(table.ok());
  for (int b = 1; b <= (*table)->height_bins(); ++b) {
    const HeightBin& bin = (*table)->bin(b);
    const double t = bin.fall.fall_time_s;
    const double sa = std::sqrt(25.0 + 4.0 * t * t + 4.0 * t * t);
    const double sc = std::sqrt(25.0 + 4.0 * t * t);
    EXPECT_DOUBLE_EQ(bin.sigma_along_m, sa);
    EXPECT_DOUBLE_EQ(bin.sigma_across_m, sc);
    EXPECT_EQ(bin.half_width, std::min(31, static_cast<int>(std::ceil(3.0 * sa / 5.0))));
    EXPECT_DOUBLE_EQ(bin.height_m, 5.0 * b);
  }
  // At 1 m cells the largest kernels reach the cap of 31.
  auto fine = ImpactTable::Build(p, 1.0);
  ASSERT_TRUE(fine.ok());
  EXPECT_EQ((*fine)->bin(60).half_width, 31);
}

TEST(ImpactTableTest, KernelIsElongatedAlongTheHeading) {
  ModelParams p;
  auto table = ImpactTable::Build(p, 5.0);
  ASSERT_TRUE(table.ok());
  // Heading east (k = 0): spread along u (east) is wider than along v (north).
  const ImpactKernel& east = (*table)->kernel(40, 0);
  const int hw = east.half_width;
  const int side = east.Stride();
  auto w = [&](const ImpactKernel& k, int u, int v) {
    return k.weights[(v + hw) * side + (u + hw)];
  };
  EXPECT_GT(w(east, 4, 0), w(east, 0, 4));
  // Heading north (k = 18): the other way round, and the kernel is the
  // east kernel rotated by 90 degrees.
  const ImpactKernel& north = (*table)->kernel(40, 18);
  EXPECT_GT(w(north, 0, 4), w(north, 4, 0));
  EXPECT_NEAR(w(north, 0, 4), w(east, 4, 0), 1e-15);
  // Offsets point along the heading at distance d(h).
  const double d = (*table)->bin(40).fall.distance_m;
  EXPECT_NEAR(east.offset_x_m, d, 1e-12);
  EXPECT_NEAR(east.offset_y_m, 0.0, 1e-12);
  EXPECT_NEAR(north.offset_x_m, 0.0, 1e-9);
  EXPECT_NEAR(north.offset_y_m, d, 1e-12);
}

TEST(ImpactTableTest, BinsRoundHalfUpAndClamp) {
  ModelParams p;
  auto table = ImpactTable::Build(p, 5.0);
  ASSERT_TRUE(table.ok());
  const ImpactTable& t = **table;
  EXPECT_EQ(t.HeightBinOf(0.1), 1);  // clamped up
  EXPECT_EQ(t.HeightBinOf(7.4), 1);
  EXPECT_EQ(t.HeightBinOf(7.5), 2);  // round half up
  EXPECT_EQ(t.HeightBinOf(100.0), 20);
  EXPECT_EQ(t.HeightBinOf(1000.0), 60);  // clamped down
  const double w = kTwoPi / 72;
  EXPECT_EQ(t.HeadingBinOf(0.0), 0);
  EXPECT_EQ(t.HeadingBinOf(0.49 * w), 0);
  EXPECT_EQ(t.HeadingBinOf(0.5 * w), 1);
  EXPECT_EQ(t.HeadingBinOf(kTwoPi - 0.4 * w), 0);  // wraps
  EXPECT_EQ(t.HeadingBinOf(kPi), 36);
  EXPECT_EQ(t.HeadingBinOf(-w), 71);
}

TEST(CasualtyProbabilityTest, Limits) {
  const double alpha = 1e6;
  const double beta = 100.0;
  // S~ = 0: 1 above beta, 0 at or below.
  EXPECT_EQ(CasualtyProbability(101.0, 0.0, alpha, beta), 1.0);
  EXPECT_EQ(CasualtyProbability(5000.0, 0.0, alpha, beta), 1.0);
  EXPECT_EQ(CasualtyProbability(100.0, 0.0, alpha, beta), 0.0);
  // E <= beta gives 0 for every shelter.
  for (double s : {0.1, 1.0, 5.0, 10.0}) {
    EXPECT_EQ(CasualtyProbability(100.0, s, alpha, beta), 0.0);
    EXPECT_EQ(CasualtyProbability(50.0, s, alpha, beta), 0.0);
  }
  // The 50 % point: S = 6 and E = alpha.
  EXPECT_NEAR(CasualtyProbability(alpha, 6.0, alpha, beta), 0.5, 1e-15);
  // Continuity towards the limits.
  EXPECT_NEAR(CasualtyProbability(5000.0, 1e-6, alpha, beta), 1.0, 1e-12);
  EXPECT_NEAR(CasualtyProbability(100.0 + 1e-9, 6.0, alpha, beta), 0.0, 1e-9);
  // More shelter, lower probability; more energy, higher.
  EXPECT_GT(CasualtyProbability(5000.0, 2.0, alpha, beta),
            CasualtyProbability(5000.0, 8.0, alpha, beta));
  EXPECT_LT(CasualtyProbability(2000.0, 5.0, alpha, beta),
            CasualtyProbability(8000.0, 5.0, alpha, beta));
}

TEST(ExposedAreaTest, MatchesFormula) {
  ModelParams p;
  const double gamma = 0.7;
  EXPECT_DOUBLE_EQ(ExposedArea(gamma, p), 2.0 * 1.3 * 1.8 / std::tan(gamma) + kPi * 1.3 * 1.3);
}

TEST(ImpactTableTest, RejectsBadParameters) {
  ModelParams p;
  p.table_max_height_m = 303.0;
  EXPECT_FALSE(ImpactTable::Build(p, 5.0).ok());
  EXPECT_FALSE(ImpactTable::Build(ModelParams{}, 0.0).ok());
  EXPECT_FALSE(ImpactTable::Build(ModelParams{}, std::nan("")).ok());
}

// The bytes a table will hold are known before it is built, exactly.
TEST(ImpactTableLimitsTest, ProjectedBytesAreTheTablesMemory) {
  for (const double res : {5.0, 1.0, 20.0}) {
    ModelParams p;
    p.heading_bins = 36;
    absl::StatusOr<double> projected = ImpactTable::ProjectedBytes(p, res);
    ASSERT_TRUE(projected.ok()) << projected.status();
    auto table = ImpactTable::Build(p, res);
    ASSERT_TRUE(table.ok()) << table.status();
    EXPECT_EQ(*projected, static_cast<double>((*table)->MemoryBytes())) << res;
    EXPECT_LE(ImpactTable::MinBytes(p), *projected) << res;
  }
}

// --max_table_bytes at, just under and just over the table's size.
TEST(ImpactTableLimitsTest, TheByteLimitAtUnderAndOver) {
  ModelParams p;
  const double bytes = *ImpactTable::ProjectedBytes(p, 5.0);
  const size_t exact = static_cast<size_t>(bytes);
  ModelBuildLimits limits;
  limits.max_table_bytes_source = "--max_table_bytes";
  limits.max_table_bytes = exact;
  EXPECT_TRUE(ImpactTable::Build(p, 5.0, limits).ok());
  limits.max_table_bytes = exact + 1;
  EXPECT_TRUE(ImpactTable::Build(p, 5.0, limits).ok());
  limits.max_table_bytes = exact - 1;
  auto over = ImpactTable::Build(p, 5.0, limits);
  ASSERT_FALSE(over.ok());
  EXPECT_EQ(over.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(over.status().message(),
            absl::StrFormat("the impact table of 'heading_bins' 72 x 60 height bins "
                            "('table_max_height_m' 300 / 'height_bin_m' 5), kernels of up to 63 x "
                            "64 weights ('max_half_width' 31), needs %.0f bytes; the limit is %d "
                            "bytes (--max_table_bytes)",
                            bytes, exact - 1));
}

// The terabyte: every value inside its range, together about a
// terabyte. Refused from the parameters alone, before any integration or
// allocation (the lower bound already exceeds the limit).
TEST(ImpactTableLimitsTest, ATerabyteTableIsRefusedBeforeAnythingIsBuilt) {
  ModelParams p;
  p.heading_bins = 3600;
  p.height_bin_m = 0.5;
  p.table_max_height_m = 5000.0;
  ASSERT_TRUE(ValidateModelParams(p).ok());
  EXPECT_GT(ImpactTable::MinBytes(p), 2e9);
  const absl::Status min = ImpactTable::CheckMinBytes(p, {});
  EXPECT_EQ(min.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(
      std::string(min.message()),
      ::testing::HasSubstr(absl::StrFormat(
          "needs at least %.0f bytes; the limit is 536870912 bytes", ImpactTable::MinBytes(p))));
  auto table = ImpactTable::Build(p, 5.0);
  ASSERT_FALSE(table.ok());
  EXPECT_EQ(table.status(), min);
  // The exact size, for the record: over a terabyte at 1 m cells.
  absl::StatusOr<double> bytes = ImpactTable::ProjectedBytes(p, 1.0);
  ASSERT_TRUE(bytes.ok());
  EXPECT_GT(*bytes, 1e12);
}

TEST(ImpactTableLimitsTest, StopsWhenAsked) {
  CancellationToken token;
  token.Cancel();
  ModelBuildLimits limits;
  limits.stop = StopCondition(&token);
  auto table = ImpactTable::Build(ModelParams{}, 5.0, limits);
  EXPECT_EQ(table.status().code(), absl::StatusCode::kCancelled);
}

}  // namespace
}  // namespace riskplan
