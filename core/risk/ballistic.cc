#include "core/risk/ballistic.h"

#include <array>
#include <cmath>

namespace riskplan {
namespace {

// State in the vertical plane: horizontal distance, fall distance (positive
// down), horizontal and downward speed.
using State = std::array<double, 4>;

State Derivative(const State& s, double g, double drag_per_mass) {
  const double vh = s[2];
  const double vz = s[3];
  const double speed = std::sqrt(vh * vh + vz * vz);
  return {vh, vz, -drag_per_mass * speed * vh, g - drag_per_mass * speed * vz};
}

State Axpy(const State& s, double a, const State& k) {
  return {s[0] + a * k[0], s[1] + a * k[1], s[2] + a * k[2], s[3] + a * k[3]};
}

}  // namespace

BallisticImpact SimulateBallisticFall(double height_m, const ModelParams& p) {
  const double g = p.gravity_mps2;
  const double drag_per_mass =
      0.5 * p.drag_coefficient * p.air_density_kgpm3 * p.frontal_area_m2 / p.mass_kg;
  const double dt = kBallisticStepS;

  State s = {0.0, 0.0, p.airspeed_mps, 0.0};
  double t = 0.0;
  BallisticImpact out;
  if (!(height_m > 0.0)) {
    out.v_horizontal_mps = p.airspeed_mps;
    out.energy_j = 0.5 * p.mass_kg * p.airspeed_mps * p.airspeed_mps;
    return out;
  }
  // Terminal velocity bounds the fall time; the cap only guards against a
  // pathological parameter set (e.g. huge drag) looping forever.
  for (int step = 0; step < 100000000; ++step) {
    const State k1 = Derivative(s, g, drag_per_mass);
    const State k2 = Derivative(Axpy(s, 0.5 * dt, k1), g, drag_per_mass);
    const State k3 = Derivative(Axpy(s, 0.5 * dt, k2), g, drag_per_mass);
    const State k4 = Derivative(Axpy(s, dt, k3), g, drag_per_mass);
    State next;
    for (int i = 0; i < 4; ++i) {
      next[i] = s[i] + dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
    if (next[1] >= height_m) {
      const double f = (height_m - s[1]) / (next[1] - s[1]);
      out.fall_time_s = t + f * dt;
      out.distance_m = s[0] + f * (next[0] - s[0]);
      out.v_horizontal_mps = s[2] + f * (next[2] - s[2]);
      out.v_vertical_mps = s[3] + f * (next[3] - s[3]);
      break;
    }
    s = next;
    t += dt;
  }
  const double vh = out.v_horizontal_mps;
  const double vz = out.v_vertical_mps;
  out.energy_j = 0.5 * p.mass_kg * (vh * vh + vz * vz);
  out.angle_rad = std::atan2(std::fabs(vz), vh);
  return out;
}

}  // namespace riskplan
