// Ballistic fall of a failed aircraft (spec section 1, thesis eq. 2.4).
#ifndef RISKPLAN_CORE_RISK_BALLISTIC_H_
#define RISKPLAN_CORE_RISK_BALLISTIC_H_

#include <cstdint>
#include <span>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/cancellation.h"
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

// The fixed integration step is kBallisticStepS (model_params.h, where the
// parameters' rules use it too). Most steps of one integration:
// kMaxFallTimeS (model_params.h) of fall.
inline constexpr int64_t kMaxBallisticSteps = 1000000;

// Integrates m dv/dt = m g - (1/2) c_d rho_air A_f |v| v in the vertical plane of
// the heading from horizontal speed params.airspeed_mps, vertical speed 0 and
// height `height_m` (> 0) above the ground, with classic RK4 at a fixed
// dt = 0.01 s, until the fall reaches the ground. The impact instant, distance
// and velocity are found by linear interpolation of the state between the last
// two steps (the one above and the one at or below the ground). A fall that
// has not reached the ground after kMaxBallisticSteps steps (only for
// parameters ValidateModelParams refuses, or at its edge) returns zeros
// but for the energy, 0 as well.
BallisticImpact SimulateBallisticFall(double height_m, const ModelParams& params);

// The falls from every height of `heights_m` (ascending, each > 0) in one
// integration: the integrated states do not depend on the height, only the
// step at which a fall stops does, so fall i is bit for bit
// SimulateBallisticFall(heights_m[i], params), for the work of the highest
// fall alone. InvalidArgument naming the parameters when the highest fall
// does not reach the ground within kMaxBallisticSteps; Cancelled when `stop`
// is reached first (it is polled every few thousand steps).
absl::StatusOr<std::vector<BallisticImpact>> SimulateBallisticFalls(
    std::span<const double> heights_m, const ModelParams& params, const StopCondition& stop = {});

}  // namespace riskplan

#endif  // RISKPLAN_CORE_RISK_BALLISTIC_H_
