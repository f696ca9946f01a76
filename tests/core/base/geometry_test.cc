// The core's geometric helpers: heading normalisation and the clamped cell
// number every grid of the planners uses.
#include "core/base/geometry.h"

#include <cmath>
#include <limits>

#include "gtest/gtest.h"

namespace riskplan {
namespace {

TEST(GeometryTest, NormalizeHeadingWrapsIntoOneTurn) {
  EXPECT_EQ(NormalizeHeading(0.0), 0.0);
  EXPECT_DOUBLE_EQ(NormalizeHeading(-kPi / 2.0), 1.5 * kPi);
  EXPECT_DOUBLE_EQ(NormalizeHeading(5.0 * kPi), kPi);
  EXPECT_EQ(NormalizeHeading(-1e-18), 0.0);  // would round to exactly 2 pi
  EXPECT_TRUE(std::isnan(NormalizeHeading(std::nan(""))));
}

TEST(GeometryTest, ClampedCellIsTheFloorOnTheGrid) {
  EXPECT_EQ(ClampedCell(0.0, 10.0, 5), 0);
  EXPECT_EQ(ClampedCell(9.999, 10.0, 5), 0);
  EXPECT_EQ(ClampedCell(10.0, 10.0, 5), 1);
  EXPECT_EQ(ClampedCell(39.9, 10.0, 5), 3);
  EXPECT_EQ(ClampedCell(49.9, 10.0, 5), 4);
  EXPECT_EQ(ClampedCell(50.0, 10.0, 5), 4);
  EXPECT_EQ(ClampedCell(-0.1, 10.0, 5), 0);
  EXPECT_EQ(ClampedCell(0.0, 10.0, 1), 0);
}

// Offsets whose cell number is beyond int's range (the fuzz targets found
// 8.2e246 m and a clearance of 1e168 m) clamp without converting out of
// range; infinities and NaN too.
TEST(GeometryTest, ClampedCellClampsOffsetsBeyondIntsRange) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(ClampedCell(8.2e246, 10.0, 100), 99);
  EXPECT_EQ(ClampedCell(-1.2e213, 10.0, 100), 0);
  EXPECT_EQ(ClampedCell(1e308, 1e-300, 100), 99);  // the quotient is infinite
  EXPECT_EQ(ClampedCell(kInf, 10.0, 100), 99);
  EXPECT_EQ(ClampedCell(-kInf, 10.0, 100), 0);
  EXPECT_EQ(ClampedCell(std::nan(""), 10.0, 100), 0);
  EXPECT_EQ(ClampedCell(21474836470.0 * 10.0, 10.0, 2147483647), 2147483646);
}

}  // namespace
}  // namespace riskplan
