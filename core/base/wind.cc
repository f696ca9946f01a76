#include "core/base/wind.h"

namespace riskplan {

WindVector WindVectorOf(double speed_mps, double from_deg) {
  if (speed_mps == 0.0) return {};
  double deg = std::fmod(from_deg, 360.0);
  if (deg < 0.0) deg += 360.0;
  const double phi = deg * (kPi / 180.0);
  return {-speed_mps * std::sin(phi), -speed_mps * std::cos(phi)};
}

WindTriangle::WindTriangle(const ModelParams& params, double airspeed_mps)
    : calm_(params.wind_speed_mps == 0.0),
      speed_(params.wind_speed_mps),
      airspeed_(airspeed_mps),
      w_(WindVectorOf(params.wind_speed_mps, params.wind_from_deg)) {}

}  // namespace riskplan
