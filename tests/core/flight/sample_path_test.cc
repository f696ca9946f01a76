// The path sampled at a spacing (display paths, exports), and the risk per
// flight hour.
#include <cmath>
#include <limits>
#include <vector>

#include "core/flight/trajectory.h"
#include "gtest/gtest.h"

namespace riskplan {
namespace {

TEST(SamplePathTest, PosesAreSpacingApartAndTheLastIsTheEnd) {
  auto pieces = PiecesFromPolyline(std::vector<Point3>{{0, 0, 100}, {100, 0, 100}, {100, 70, 100}});
  ASSERT_TRUE(pieces.ok());
  const std::vector<PathPose> path = SamplePath(*pieces, 40.0, 1000);
  // 170 m: 0, 40, 80, 120, 160, then 170.
  ASSERT_EQ(path.size(), 6u);
  EXPECT_EQ(PathPoseCount(170.0, 40.0), 6);
  const double expected[] = {0, 40, 80, 120, 160, 170};
  for (size_t k = 0; k < path.size(); ++k) EXPECT_DOUBLE_EQ(path[k].arc_length_m, expected[k]);
  EXPECT_DOUBLE_EQ(path[1].pose.x, 40.0);
  EXPECT_EQ(path[1].piece, 0);
  EXPECT_DOUBLE_EQ(path[3].pose.x, 100.0);  // 20 m up the second piece
  EXPECT_DOUBLE_EQ(path[3].pose.y, 20.0);
  EXPECT_EQ(path[3].piece, 1);
  EXPECT_DOUBLE_EQ(path.back().pose.y, 70.0);
  // A length that the spacing divides: no pose twice at the end.
  const std::vector<PathPose> even = SamplePath(*pieces, 85.0, 1000);
  ASSERT_EQ(even.size(), 3u);
  EXPECT_EQ(PathPoseCount(170.0, 85.0), 3);
  EXPECT_DOUBLE_EQ(even[1].arc_length_m, 85.0);
  EXPECT_DOUBLE_EQ(even[2].arc_length_m, 170.0);
}

TEST(SamplePathTest, TheBoundKeepsTheEnd) {
  auto pieces = PiecesFromPolyline(std::vector<Point3>{{0, 0, 100}, {1000, 0, 100}});
  ASSERT_TRUE(pieces.ok());
  const std::vector<PathPose> path = SamplePath(*pieces, 1.0, 10);
  ASSERT_EQ(path.size(), 10u);
  EXPECT_DOUBLE_EQ(path[8].arc_length_m, 8.0);
  EXPECT_DOUBLE_EQ(path.back().pose.x, 1000.0);
  EXPECT_EQ(PathPoseCount(0.0, 5.0), 1);
  EXPECT_EQ(PathPoseCount(1e300, 1.0), std::numeric_limits<int64_t>::max());
}

TEST(SamplePathTest, RiskPerFlightHourIsRiskOverFlightHours) {
  EXPECT_DOUBLE_EQ(FlightTimeS(1800.0, 18.0), 100.0);
  EXPECT_DOUBLE_EQ(RiskPerFlightHour(1e-7, 100.0), 3.6e-6);
  EXPECT_EQ(RiskPerFlightHour(0.0, 0.0), 0.0);
}

}  // namespace
}  // namespace riskplan
