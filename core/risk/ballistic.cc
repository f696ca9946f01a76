#include "core/risk/ballistic.h"

#include <array>
#include <cmath>

#include "absl/strings/str_format.h"
#include "core/base/check.h"

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

// Energy and angle from the impact velocity.
void Finish(const ModelParams& p, BallisticImpact* out) {
  const double vh = out->v_horizontal_mps;
  const double vz = out->v_vertical_mps;
  out->energy_j = 0.5 * p.mass_kg * (vh * vh + vz * vz);
  out->angle_rad = std::atan2(std::fabs(vz), vh);
}

// The one integration behind both entry points: records the impact of
// heights_m[0], [1], ... in turn as the fall passes them (ascending, > 0).
// Returns how many were reached before the step cap or `stop`; *stopped
// tells which of the two ended it early.
size_t Integrate(std::span<const double> heights_m, const ModelParams& p, const StopCondition& stop,
                 std::vector<BallisticImpact>* out, bool* stopped) {
  const double g = p.gravity_mps2;
  const double drag_per_mass =
      0.5 * p.drag_coefficient * p.air_density_kgpm3 * p.frontal_area_m2 / p.mass_kg;
  const double dt = kBallisticStepS;
  *stopped = false;
  State s = {0.0, 0.0, p.airspeed_mps, 0.0};
  double t = 0.0;
  size_t next_height = 0;
  // Terminal velocity bounds the fall time (ValidateModelParams refuses a
  // parameter set whose fall certainly lasts longer than the cap).
  for (int64_t step = 0; step < kMaxBallisticSteps && next_height < heights_m.size(); ++step) {
    if (step % 4096 == 4095 && stop.Reached()) {
      *stopped = true;
      break;
    }
    const State k1 = Derivative(s, g, drag_per_mass);
    const State k2 = Derivative(Axpy(s, 0.5 * dt, k1), g, drag_per_mass);
    const State k3 = Derivative(Axpy(s, 0.5 * dt, k2), g, drag_per_mass);
    const State k4 = Derivative(Axpy(s, dt, k3), g, drag_per_mass);
    State next;
    for (int i = 0; i < 4; ++i) {
      next[i] = s[i] + dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
    // Every height this step reaches, with the same interpolation a fall
    // from that height alone would make.
    while (next_height < heights_m.size() && next[1] >= heights_m[next_height]) {
      const double height_m = heights_m[next_height];
      const double f = (height_m - s[1]) / (next[1] - s[1]);
      BallisticImpact& impact = (*out)[next_height];
      impact.fall_time_s = t + f * dt;
      impact.distance_m = s[0] + f * (next[0] - s[0]);
      impact.v_horizontal_mps = s[2] + f * (next[2] - s[2]);
      impact.v_vertical_mps = s[3] + f * (next[3] - s[3]);
      Finish(p, &impact);
      ++next_height;
    }
    s = next;
    t += dt;
  }
  return next_height;
}

}  // namespace

BallisticImpact SimulateBallisticFall(double height_m, const ModelParams& p) {
  BallisticImpact out;
  if (!(height_m > 0.0)) {
    out.v_horizontal_mps = p.airspeed_mps;
    out.energy_j = 0.5 * p.mass_kg * p.airspeed_mps * p.airspeed_mps;
    return out;
  }
  std::vector<BallisticImpact> impacts(1);
  bool stopped = false;
  if (Integrate(std::span<const double>(&height_m, 1), p, StopCondition(), &impacts, &stopped) ==
      0) {
    Finish(p, &out);  // never reached the ground: zero velocity
    return out;
  }
  return impacts[0];
}

absl::StatusOr<std::vector<BallisticImpact>> SimulateBallisticFalls(
    std::span<const double> heights_m, const ModelParams& p, const StopCondition& stop) {
  for (size_t i = 0; i < heights_m.size(); ++i) {
    RISKPLAN_DCHECK(heights_m[i] > 0.0 && (i == 0 || heights_m[i - 1] <= heights_m[i]));
  }
  std::vector<BallisticImpact> out(heights_m.size());
  bool stopped = false;
  const size_t reached = Integrate(heights_m, p, stop, &out, &stopped);
  if (reached == heights_m.size()) return out;
  if (stopped) return absl::CancelledError("ballistic fall: stopped before it reached the ground");
  return absl::InvalidArgumentError(absl::StrFormat(
      "parameters 'mass_kg' (%g), 'drag_coefficient' (%g), 'frontal_area_m2' (%g), "
      "'air_density_kgpm3' (%g) and 'gravity_mps2' (%g): a ballistic fall from %g m has not "
      "reached the ground after %g s; at most %g s of fall is simulated",
      p.mass_kg, p.drag_coefficient, p.frontal_area_m2, p.air_density_kgpm3, p.gravity_mps2,
      heights_m[reached], kMaxBallisticSteps * kBallisticStepS, kMaxFallTimeS));
}

}  // namespace riskplan
