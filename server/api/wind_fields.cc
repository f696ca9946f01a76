#include "server/api/wind_fields.h"

#include <cmath>
#include <numbers>
#include <string>

#include "absl/strings/str_format.h"
#include "core/base/wind.h"
#include "server/api/field_checks.h"
#include "server/api/wgs84_fields.h"

namespace riskplan::server {
namespace {

constexpr double kDegPerRad = 180.0 / std::numbers::pi;

// Into [0, 360).
double NormalizeDeg(double deg) {
  double d = std::fmod(deg, 360.0);
  if (d < 0.0) d += 360.0;
  if (d >= 360.0) d = 0.0;  // -1e-17 + 360 rounds to 360
  return d;
}

// A speed inside [0, 0.5 v]; `subject` says which, e.g. "wind.from.speed_mps
// has value 10".
absl::Status CheckWindSpeed(double speed, const std::string& subject, const ModelParams& params) {
  if (!(speed >= 0.0)) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s; a wind speed must be >= 0 m/s", subject));
  }
  const double limit = kMaxWindFraction * params.airspeed_mps;
  if (speed > limit) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s; it must be at most %g * model_params.airspeed_mps = %g m/s (airspeed %g m/s): the "
        "wind may be at most half the airspeed",
        subject, kMaxWindFraction, limit, params.airspeed_mps));
  }
  return absl::OkStatus();
}

// speed_mps and from_deg of a WindFrom at `field`, checked.
absl::Status WindFromFields(const v1::WindFrom& from, const std::string& field,
                            const ModelParams& params, double* speed, double* from_deg) {
  if (absl::Status s = CheckFinite(from.speed_mps(), field + ".speed_mps"); !s.ok()) return s;
  if (absl::Status s = CheckFinite(from.from_deg(), field + ".from_deg"); !s.ok()) {
    return absl::Status(s.code(), std::string(s.message()) +
                                      " (any finite direction is taken modulo 360)");
  }
  if (absl::Status s = CheckWindSpeed(
          from.speed_mps(), absl::StrFormat("%s.speed_mps has value %g", field, from.speed_mps()),
          params);
      !s.ok()) {
    return s;
  }
  *speed = from.speed_mps();
  *from_deg = from.from_deg();
  return absl::OkStatus();
}

}  // namespace

absl::Status ApplyRequestWind(const RequestWind& request, const MapRegistry& registry,
                              const RiskMap& map, ModelParams* params) {
  if (request.wind == nullptr && request.wind_wgs84 == nullptr) return absl::OkStatus();
  const char* given = request.wind != nullptr ? "wind" : "wind_wgs84";
  if (request.model_params != nullptr && (request.model_params->has_wind_speed_mps() ||
                                          request.model_params->has_wind_from_deg())) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s and model_params.%s both give the wind; give it once", given,
        request.model_params->has_wind_speed_mps() ? "wind_speed_mps" : "wind_from_deg"));
  }
  double speed = 0.0;
  double from_deg = 0.0;
  if (request.wind != nullptr) {
    const v1::Wind& w = *request.wind;
    switch (w.form_case()) {
      case v1::Wind::kFrom:
        if (absl::Status s = WindFromFields(w.from(), "wind.from", *params, &speed, &from_deg);
            !s.ok()) {
          return s;
        }
        break;
      case v1::Wind::kVector: {
        if (absl::Status s = CheckFinite(w.vector().x_mps(), "wind.vector.x_mps"); !s.ok()) return s;
        if (absl::Status s = CheckFinite(w.vector().y_mps(), "wind.vector.y_mps"); !s.ok()) return s;
        speed = std::hypot(w.vector().x_mps(), w.vector().y_mps());
        if (absl::Status s = CheckWindSpeed(
                speed,
                absl::StrFormat("wind.vector (x_mps %g, y_mps %g) has speed %g m/s",
                                w.vector().x_mps(), w.vector().y_mps(), speed),
                *params);
            !s.ok()) {
          return s;
        }
        // The air moves to (x, y) = -W (sin phi, cos phi): phi = atan2(-x, -y).
        from_deg = speed > 0.0 ? NormalizeDeg(std::atan2(-w.vector().x_mps(), -w.vector().y_mps()) *
                                              kDegPerRad)
                               : 0.0;
        break;
      }
      case v1::Wind::FORM_NOT_SET:
        return absl::InvalidArgumentError(
            "wind is set but gives neither wind.from (speed_mps, from_deg) nor wind.vector "
            "(x_mps, y_mps)");
    }
  } else {
    absl::StatusOr<std::shared_ptr<const geo::GeoFrame>> frame =
        FrameForField(registry, map, "wind_wgs84", "wind");
    if (!frame.ok()) return frame.status();
    if (!request.wind_wgs84->has_from()) {
      return absl::InvalidArgumentError(
          "wind_wgs84 is set but has no wind_wgs84.from (speed_mps, from_deg from true north)");
    }
    double from_true = 0.0;
    if (absl::Status s =
            WindFromFields(request.wind_wgs84->from(), "wind_wgs84.from", *params, &speed, &from_true);
        !s.ok()) {
      return s;
    }
    from_deg = NormalizeDeg(NormalizeDeg(from_true) - MapConvergenceDeg(map, frame->get()));
  }
  params->wind_speed_mps = speed;
  params->wind_from_deg = from_deg;
  // The ranges and rules again (the bound above is the rule's; this is a
  // guard that the parameters stay a valid set).
  return InField(given, ValidateModelParams(*params));
}

double MapConvergenceDeg(const RiskMap& map, const geo::GeoFrame* frame) {
  if (frame == nullptr) return 0.0;
  const geo::LocalXY centre{map.x0() + 0.5 * map.width_m(), map.y0() + 0.5 * map.height_m()};
  absl::StatusOr<double> gamma = frame->GridConvergenceRad(centre);
  return gamma.ok() ? *gamma * kDegPerRad : 0.0;
}

v1::WindReport WindReportOf(const ModelParams& params, const RiskMap& map,
                            const geo::GeoFrame* frame) {
  v1::WindReport out;
  out.set_speed_mps(params.wind_speed_mps);
  const double from = NormalizeDeg(params.wind_from_deg);
  out.set_from_deg(from);
  const WindVector w = WindVectorOf(params.wind_speed_mps, params.wind_from_deg);
  out.set_x_mps(w.x);
  out.set_y_mps(w.y);
  out.set_airspeed_mps(params.airspeed_mps);
  out.set_glide_airspeed_mps(params.GlideAirspeed());
  if (frame != nullptr) out.set_from_true_deg(NormalizeDeg(from + MapConvergenceDeg(map, frame)));
  return out;
}

}  // namespace riskplan::server
