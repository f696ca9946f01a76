// The mean wind and the wind triangle (spec version 3, section 0).
//
// The wind vector, in the map frame (where the air moves to), is
//   w = -W (sin phi_w, cos phi_w), phi_w the direction it blows from,
// clockwise from north. For a track heading theta (the course over the
// ground), with t = (cos theta, sin theta) and n = (-sin theta, cos theta):
//   air heading   psi(theta) = theta - asin((w . n) / v), in [0, 2 pi);
//   ground speed  gs(theta)  = sqrt(v^2 - (w . n)^2) + w . t.
// In still air (W = 0) psi is theta itself and gs is v, bit for bit: every
// number of the model is then version 2's.
//
// A value type; cheap to copy (five doubles).
#ifndef RISKPLAN_CORE_BASE_WIND_H_
#define RISKPLAN_CORE_BASE_WIND_H_

#include <cmath>

#include "core/base/geometry.h"
#include "core/base/model_params.h"

namespace riskplan {

// (w_x, w_y) of a wind of `speed_mps` blowing from `from_deg` (degrees
// clockwise from north, any finite value): the direction is taken modulo
// 360 first, so 370 and 10 give the same vector bit for bit.
struct WindVector {
  double x = 0.0;
  double y = 0.0;
};
WindVector WindVectorOf(double speed_mps, double from_deg);

class WindTriangle {
 public:
  // The wind of `params` (wind_speed_mps, wind_from_deg) for an aircraft at
  // airspeed `airspeed_mps` (the cruise airspeed v, or the glide's v_g).
  // REQUIRES: airspeed_mps > 0.
  WindTriangle(const ModelParams& params, double airspeed_mps);
  // The cruise: airspeed v = params.airspeed_mps.
  explicit WindTriangle(const ModelParams& params)
      : WindTriangle(params, params.airspeed_mps) {}

  bool calm() const { return calm_; }
  double speed_mps() const { return speed_; }
  double airspeed_mps() const { return airspeed_; }
  const WindVector& vector() const { return w_; }

  // w . n and w . t for track heading theta: the cross-wind (positive from
  // the right, i.e. pushing the aircraft left) and the tail-wind components.
  double CrossWind(double theta) const { return -w_.x * std::sin(theta) + w_.y * std::cos(theta); }
  double TailWind(double theta) const { return w_.x * std::cos(theta) + w_.y * std::sin(theta); }

  // psi(theta), normalised to [0, 2 pi); theta itself when calm().
  // Needs |w . n| <= v (always true for W <= v; the model bounds W by v / 2).
  double AirHeading(double theta) const {
    if (calm_) return theta;
    return NormalizeHeading(theta - std::asin(CrossWind(theta) / airspeed_));
  }
  // gs(theta); exactly the airspeed when calm().
  double GroundSpeed(double theta) const {
    if (calm_) return airspeed_;
    // CrossWind and TailWind with one sine and one cosine (the same doubles).
    const double s = std::sin(theta);
    const double c = std::cos(theta);
    const double cross = -w_.x * s + w_.y * c;
    const double tail = w_.x * c + w_.y * s;
    return std::sqrt(airspeed_ * airspeed_ - cross * cross) + tail;
  }

 private:
  bool calm_ = true;
  double speed_ = 0.0;
  double airspeed_ = 0.0;
  WindVector w_;
};

}  // namespace riskplan

#endif  // RISKPLAN_CORE_BASE_WIND_H_
