// Ballistic fall of a failed aircraft (spec section 1, thesis eq. 2.4).
#ifndef RISKPLAN_CORE_RISK_BALLISTIC_H_
#define RISKPLAN_CORE_RISK_BALLISTIC_H_

#include "core/base/model_params.h"

namespace riskplan {

struct BallisticImpact {
  double distance_m = 0.0;        // d(h): horizontal distance travelled
  double fall_time_s = 0.0;       // t_f(h)
  double v_horizontal_mps = 0.0;  // v_h at impact (>= 0, along the heading)
  double v_vertical_mps = 0.0;    // v_z at impact (>= 0, downwards)
  double energy_j = 0.0;          // E = m (v_h^2 + v_z^2) / 2
  double angle_rad = 0.0;         // gamma = atan2(|v_z|, v_h)
};

// Integrates m dv/dt = m g - (1/2) c_d rho_air A_f |v| v in the vertical plane of
// the heading from horizontal speed params.airspeed_mps, vertical speed 0 and
// height `height_m` (> 0) above the ground, with classic RK4 at a fixed
// dt = 0.01 s, until the fall reaches the ground. The impact instant, distance
// and velocity are found by linear interpolation of the state between the last
// two steps (the one above and the one at or below the ground).
BallisticImpact SimulateBallisticFall(double height_m, const ModelParams& params);

// The fixed integration step of SimulateBallisticFall.
inline constexpr double kBallisticStepS = 0.01;

}  // namespace riskplan

#endif  // RISKPLAN_CORE_RISK_BALLISTIC_H_
