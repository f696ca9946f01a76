#include "core/risk/ballistic.h"

#include <cmath>

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

}  // namespace
}  // namespace riskplan
