#include "core/risk/ballistic.h"

#include <cmath>
#include <string>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace riskplan {
namespace {

TEST(BallisticFallTest, DragFreeMatchesClosedForm) {
  ModelParams p;
  p.drag_coefficient = 0.0;
  for (double h : {5.0, 20.0, 100.0, 300.0}) {
    const BallisticImpact fall = SimulateBallisticFall(h, p);
    const double t = std::sqrt(2.0 * h / p.gravity_mps2);
    // RK4 is exact for this quadratic motion; the only error is the linear
    // interpolation of the impact instant inside the last 0.01 s step, which is
    // at most g*dt^2/8 in fall distance.
    EXPECT_NEAR(fall.fall_time_s, t, 1e-4) << "h=" << h;
    EXPECT_NEAR(fall.distance_m, p.airspeed_mps * t, 2e-3) << "h=" << h;
    EXPECT_NEAR(fall.v_horizontal_mps, p.airspeed_mps, 1e-12);
    EXPECT_NEAR(fall.v_vertical_mps, p.gravity_mps2 * t, 1e-3) << "h=" << h;
    const double energy =
        0.5 * p.mass_kg * (p.airspeed_mps * p.airspeed_mps + 2.0 * p.gravity_mps2 * h);
    EXPECT_NEAR(fall.energy_j, energy, 1e-4 * energy) << "h=" << h;
    EXPECT_NEAR(fall.angle_rad, std::atan2(p.gravity_mps2 * t, p.airspeed_mps), 1e-5);
  }
}

TEST(BallisticFallTest, DragSlowsTheFallBelowTerminalVelocity) {
  ModelParams p;
  const double terminal = std::sqrt(2.0 * p.mass_kg * p.gravity_mps2 /
                                    (p.drag_coefficient * p.air_density_kgpm3 * p.frontal_area_m2));
  ModelParams vacuum = p;
  vacuum.drag_coefficient = 0.0;
  for (double h : {10.0, 100.0, 300.0}) {
    const BallisticImpact with_drag = SimulateBallisticFall(h, p);
    const BallisticImpact without = SimulateBallisticFall(h, vacuum);
    EXPECT_GT(with_drag.fall_time_s, without.fall_time_s);
    EXPECT_LT(with_drag.distance_m, without.distance_m);
    EXPECT_LT(with_drag.energy_j, without.energy_j);
    const double speed = std::hypot(with_drag.v_horizontal_mps, with_drag.v_vertical_mps);
    EXPECT_LT(speed, std::max(terminal, p.airspeed_mps));
  }
  // After a long fall the vertical speed approaches terminal velocity (31.6 m/s).
  const BallisticImpact long_fall = SimulateBallisticFall(3000.0, p);
  EXPECT_NEAR(long_fall.v_vertical_mps, terminal, 0.01 * terminal);
  EXPECT_NEAR(terminal, 31.64, 0.01);
}

TEST(BallisticFallTest, MonotoneInHeight) {
  ModelParams p;
  BallisticImpact previous = SimulateBallisticFall(5.0, p);
  for (double h = 10.0; h <= 300.0; h += 5.0) {
    const BallisticImpact fall = SimulateBallisticFall(h, p);
    EXPECT_GT(fall.fall_time_s, previous.fall_time_s);
    EXPECT_GT(fall.distance_m, previous.distance_m);
    EXPECT_GT(fall.energy_j, previous.energy_j);
    EXPECT_GT(fall.angle_rad, previous.angle_rad);
    previous = fall;
  }
}

// The impact table integrates once for all its height bins: each height's
// impact must be bit for bit that of its own integration.
TEST(BallisticFallsTest, OneIntegrationGivesEveryHeightItsOwnFallBitForBit) {
  for (const double drag : {0.8, 0.0}) {
    ModelParams p;
    p.drag_coefficient = drag;
    std::vector<double> heights;
    for (int b = 1; b <= 60; ++b) heights.push_back(b * 5.0);
    heights.push_back(300.0);  // a repeated height
    absl::StatusOr<std::vector<BallisticImpact>> falls = SimulateBallisticFalls(heights, p);
    ASSERT_TRUE(falls.ok()) << falls.status();
    ASSERT_EQ(falls->size(), heights.size());
    for (size_t i = 0; i < heights.size(); ++i) {
      const BallisticImpact one = SimulateBallisticFall(heights[i], p);
      const BallisticImpact& all = (*falls)[i];
      EXPECT_EQ(all.fall_time_s, one.fall_time_s) << heights[i];
      EXPECT_EQ(all.distance_m, one.distance_m) << heights[i];
      EXPECT_EQ(all.v_horizontal_mps, one.v_horizontal_mps) << heights[i];
      EXPECT_EQ(all.v_vertical_mps, one.v_vertical_mps) << heights[i];
      EXPECT_EQ(all.energy_j, one.energy_j) << heights[i];
      EXPECT_EQ(all.angle_rad, one.angle_rad) << heights[i];
    }
  }
}

// A fall the cap cannot hold (ValidateModelParams lets such a set through
// only at the edge of its fall-time rule) is an error naming the parameters,
// not a table of zeros.
TEST(BallisticFallsTest, AFallLongerThanTheCapIsRefused) {
  ModelParams p;
  p.gravity_mps2 = 0.1;
  p.airspeed_mps = 1.0;
  p.air_density_kgpm3 = 10.0;
  p.drag_coefficient = 2.0;
  p.frontal_area_m2 = 1.0;
  p.mass_kg = 0.2;  // terminal velocity 4.5 cm/s: about 11 000 s from 500 m
  const std::vector<double> heights = {1.0, 500.0};
  absl::StatusOr<std::vector<BallisticImpact>> falls = SimulateBallisticFalls(heights, p);
  ASSERT_FALSE(falls.ok());
  EXPECT_EQ(falls.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(falls.status().message()),
              ::testing::HasSubstr("a ballistic fall from 500 m has not reached the ground "
                                   "after 10000 s; at most 10000 s of fall is simulated"));
  EXPECT_THAT(std::string(falls.status().message()), ::testing::HasSubstr("'mass_kg' (0.2)"));
}

TEST(BallisticFallsTest, StopsWhenAsked) {
  ModelParams p;
  CancellationToken token;
  token.Cancel();
  const std::vector<double> heights = {5000.0};
  absl::StatusOr<std::vector<BallisticImpact>> falls =
      SimulateBallisticFalls(heights, p, StopCondition(&token));
  EXPECT_EQ(falls.status().code(), absl::StatusCode::kCancelled);
}

}  // namespace
}  // namespace riskplan
