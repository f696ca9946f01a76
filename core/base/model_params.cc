#include "core/base/model_params.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "absl/strings/str_format.h"

namespace riskplan {
namespace {

struct FieldRef {
  double ModelParams::*real = nullptr;
  int ModelParams::*integer = nullptr;
  ModelParamRange range;
};

FieldRef Real(double ModelParams::*field, std::string_view name, double min_value, double max_value,
              std::string_view why) {
  return FieldRef{field, nullptr, ModelParamRange{name, min_value, max_value, false, why}};
}

FieldRef Whole(int ModelParams::*field, std::string_view name, double min_value, double max_value,
               std::string_view why) {
  return FieldRef{nullptr, field, ModelParamRange{name, min_value, max_value, true, why}};
}

// One table for SetModelParam, GetModelParam, ModelParamNames and the ranges
// ValidateModelParams checks, so that a new field needs one entry here.
// Every bound is closed, so the table prints as [min, max] everywhere.
const std::vector<FieldRef>& Fields() {
  static const auto* fields = new std::vector<FieldRef>{
      Real(&ModelParams::mass_kg, "mass_kg", 0.01, 1000.0,
           "from a 10 g micro drone to a tonne; the mass divides the drag of the ballistic fall"),
      Real(&ModelParams::drag_coefficient, "drag_coefficient", 0.0, 10.0,
           "0 is a fall in vacuum; a flat plate across the flow is about 2"),
      Real(&ModelParams::frontal_area_m2, "frontal_area_m2", 0.0, 100.0,
           "0 is a fall without drag"),
      Real(&ModelParams::airspeed_mps, "airspeed_mps", 1.0, 200.0,
           "a fixed wing flies above its stall speed, at least 1 m/s even indoors; the risk per "
           "metre is lambda / v"),
      Real(&ModelParams::uav_radius_m, "uav_radius_m", 0.0, 50.0, "a point to a 100 m wingspan"),
      Real(&ModelParams::turn_radius_m, "turn_radius_m", 1.0, 10000.0,
           "no fixed wing turns tighter than 1 m at flying speed; a climb's spiral makes "
           "abs(dz) / (2 pi R tan(max_climb_rad)) turns"),
      Real(&ModelParams::max_climb_rad, "max_climb_rad", 0.01, 1.4,
           "a 1 % gradient (0.57 degrees) is below any aircraft's certified climb; a climb of dz "
           "needs abs(dz) / tan(max_climb_rad) of horizontal flight; 1.4 rad is 80 degrees"),
      Real(&ModelParams::failure_rate_per_s, "failure_rate_per_s", 0.0, 1.0,
           "0 never fails; 1 fails every second"),
      Real(&ModelParams::gravity_mps2, "gravity_mps2", 0.1, 30.0,
           "from a small moon (Ceres 0.28) to Jupiter (24.8); a fall lasts at least "
           "sqrt(2 h / g)"),
      Real(&ModelParams::air_density_kgpm3, "air_density_kgpm3", 0.0, 10.0,
           "0 is vacuum; Titan's surface air is 5.4"),
      Real(&ModelParams::person_radius_m, "person_radius_m", 0.0, 10.0,
           "exposed-area model of a person"),
      Real(&ModelParams::person_height_m, "person_height_m", 0.0, 10.0,
           "exposed-area model of a person"),
      Real(&ModelParams::alpha_j, "alpha_j", 1.0, 1e12,
           "impact energy at which p_cas is 1/2 with shelter 6; must exceed beta_j"),
      Real(&ModelParams::beta_j, "beta_j", 1.0, 1e12,
           "energy below which an impact never kills (the literature uses 34 to 100 J); below 1 J "
           "sqrt(alpha / beta) and (beta / E)^(3 / S) leave the range of a double"),
      Real(&ModelParams::sigma_pos_m, "sigma_pos_m", 0.01, 1000.0,
           "RTK positioning reaches about 1 cm; its inverse square weighs the impact kernel, so 0 "
           "would divide by zero"),
      Real(&ModelParams::sigma_speed_mps, "sigma_speed_mps", 0.0, 100.0,
           "spread of the speed at failure"),
      Real(&ModelParams::sigma_wind_mps, "sigma_wind_mps", 0.0, 100.0, "gusts up to a hurricane's"),
      Whole(&ModelParams::heading_bins, "heading_bins", 1.0, 3600.0,
            "down to a tenth of a degree; the table's size is also bounded (--max_table_bytes)"),
      Real(&ModelParams::height_bin_m, "height_bin_m", 0.1, 1000.0,
           "finer than 10 cm is below any terrain model's accuracy"),
      Real(&ModelParams::table_max_height_m, "table_max_height_m", 0.1, 5000.0,
           "a small UAV flies below 5 km above the ground; a multiple of height_bin_m"),
      Whole(&ModelParams::max_half_width, "max_half_width", 0.0, 63.0,
            "kernels of at most 127 x 127 cells, the maps' padding (RiskMap::kPad)"),
      Real(&ModelParams::sample_step_m, "sample_step_m", 0.1, 1000.0,
           "M is constant over a map cell and a height bin, so steps under 10 cm add cost, not "
           "accuracy; the samples of a trajectory and of a planner's edge are also bounded "
           "(--max_eval_samples, --max_edge_samples)"),
      Real(&ModelParams::min_agl_m, "min_agl_m", 0.0, 10000.0,
           "bottom of the flight band above the terrain"),
      Real(&ModelParams::max_agl_m, "max_agl_m", 1.0, 10000.0,
           "top of the flight band, above min_agl_m"),
      Real(
          &ModelParams::glide_ratio, "glide_ratio", 1.0, 1000.0,
          "below 1 (steeper than 45 degrees) is a fall, not a glide; the best sailplanes reach 70"),
      Real(&ModelParams::glide_clearance_m, "glide_clearance_m", 0.0, 1000.0,
           "terrain clearance of an emergency glide"),
      Real(&ModelParams::wind_speed_mps, "wind_speed_mps", 0.0, 100.0,
           "mean wind speed W; the model also bounds it by half the airspeed (a rule below)"),
      Real(&ModelParams::wind_from_deg, "wind_from_deg", -std::numeric_limits<double>::max(),
           std::numeric_limits<double>::max(),
           "direction the wind blows from, degrees clockwise from north; any finite value, "
           "taken modulo 360"),
      Real(&ModelParams::glide_airspeed_mps, "glide_airspeed_mps", 0.0, 200.0,
           "airspeed of the emergency glide v_g; 0 (the default) is the cruise airspeed"),
  };
  return *fields;
}

}  // namespace

absl::Status SetModelParam(ModelParams* params, std::string_view name, double value) {
  for (const FieldRef& f : Fields()) {
    if (f.range.name != name) continue;
    if (f.real != nullptr) {
      params->*f.real = value;
      return absl::OkStatus();
    }
    if (!std::isfinite(value) || value != std::floor(value) || std::fabs(value) > 1e9) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "parameter '%s' has value %g; it must be a whole number", std::string(name), value));
    }
    params->*f.integer = static_cast<int>(value);
    return absl::OkStatus();
  }
  return absl::InvalidArgumentError(
      absl::StrFormat("unknown model parameter '%s'", std::string(name)));
}

absl::StatusOr<double> GetModelParam(const ModelParams& params, std::string_view name) {
  for (const FieldRef& f : Fields()) {
    if (f.range.name != name) continue;
    return f.real != nullptr ? params.*f.real : static_cast<double>(params.*f.integer);
  }
  return absl::NotFoundError(absl::StrFormat("unknown model parameter '%s'", std::string(name)));
}

const std::vector<std::string_view>& ModelParamNames() {
  static const auto* names = [] {
    auto* v = new std::vector<std::string_view>;
    for (const FieldRef& f : Fields()) v->push_back(f.range.name);
    return v;
  }();
  return *names;
}

int ModelParams::HeightBins() const {
  return static_cast<int>(std::lround(table_max_height_m / height_bin_m));
}

const std::vector<ModelParamRange>& ModelParamRanges() {
  static const auto* ranges = [] {
    auto* v = new std::vector<ModelParamRange>;
    for (const FieldRef& f : Fields()) v->push_back(f.range);
    return v;
  }();
  return *ranges;
}

const std::vector<std::string_view>& ModelParamRules() {
  static const auto* rules = new std::vector<std::string_view>{
      "alpha_j > beta_j",
      "table_max_height_m is a multiple of height_bin_m, with 1 to 10000 height bins",
      "max_agl_m > min_agl_m",
      "a ballistic fall from table_max_height_m lasts at most 10000 s: max(h / v_t, "
      "sqrt(2 h / g)) <= 10000 s, with v_t = sqrt(2 mass_kg gravity_mps2 / "
      "(air_density_kgpm3 drag_coefficient frontal_area_m2)), the terminal velocity",
      "the drag's time constant 1 / (k max(airspeed_mps, v_t)), with k = air_density_kgpm3 "
      "drag_coefficient frontal_area_m2 / (2 mass_kg), is at least the ballistic "
      "integration's fixed step of 0.01 s",
      "wind_speed_mps <= 0.5 airspeed_mps (every ground speed is then at least half the airspeed)",
  };
  return *rules;
}

double FallTimeLowerBound(double height_m, const ModelParams& p) {
  if (!(height_m > 0.0)) return 0.0;
  const double free_fall_s = std::sqrt(2.0 * height_m / p.gravity_mps2);
  const double drag = p.air_density_kgpm3 * p.drag_coefficient * p.frontal_area_m2;
  if (!(drag > 0.0)) return free_fall_s;
  // The downward speed never exceeds v_t: drag grows with the whole speed,
  // so it brakes the fall at least as hard as in a vertical drop.
  const double terminal_mps = std::sqrt(2.0 * p.mass_kg * p.gravity_mps2 / drag);
  return std::max(free_fall_s, height_m / terminal_mps);
}

absl::Status ValidateModelParams(const ModelParams& p) {
  for (const FieldRef& f : Fields()) {
    const double value = f.real != nullptr ? p.*f.real : static_cast<double>(p.*f.integer);
    const ModelParamRange& r = f.range;
    if (!std::isfinite(value) || value < r.min_value || value > r.max_value) {
      return absl::InvalidArgumentError(
          absl::StrFormat("parameter '%s' has value %g; it must be finite and in [%g, %g]",
                          std::string(r.name), value, r.min_value, r.max_value));
    }
  }
  if (p.alpha_j <= p.beta_j) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "parameter 'alpha_j' (%g) must be greater than 'beta_j' (%g)", p.alpha_j, p.beta_j));
  }
  const double bins = p.table_max_height_m / p.height_bin_m;
  if (std::fabs(bins - std::round(bins)) > 1e-9 * bins || bins < 1.0 || bins > 10000.0) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "parameter 'table_max_height_m' (%g) must be a multiple of 'height_bin_m' (%g), with "
        "1 to 10000 bins",
        p.table_max_height_m, p.height_bin_m));
  }
  if (p.max_agl_m <= p.min_agl_m) {
    return absl::InvalidArgumentError(
        absl::StrFormat("parameter 'max_agl_m' (%g) must be greater than 'min_agl_m' (%g)",
                        p.max_agl_m, p.min_agl_m));
  }
  if (p.wind_speed_mps > kMaxWindFraction * p.airspeed_mps) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "parameter 'wind_speed_mps' (%g) must be at most %g times 'airspeed_mps' (%g), i.e. %g "
        "m/s: the model's wind triangle needs a ground speed of at least half the airspeed",
        p.wind_speed_mps, kMaxWindFraction, p.airspeed_mps, kMaxWindFraction * p.airspeed_mps));
  }
  // Each parameter in range can still make the fall last days (a light,
  // draggy body in thick air): refused here, before the impact table
  // integrates anything.
  if (const double t = FallTimeLowerBound(p.table_max_height_m, p); !(t <= kMaxFallTimeS)) {
    const double drag = p.air_density_kgpm3 * p.drag_coefficient * p.frontal_area_m2;
    return absl::InvalidArgumentError(absl::StrFormat(
        "parameters 'mass_kg' (%g), 'drag_coefficient' (%g), 'frontal_area_m2' (%g), "
        "'air_density_kgpm3' (%g) and 'gravity_mps2' (%g) give a terminal velocity of %.3g m/s: "
        "a fall from 'table_max_height_m' (%g m) lasts at least %.3g s; at most %g s of fall is "
        "simulated",
        p.mass_kg, p.drag_coefficient, p.frontal_area_m2, p.air_density_kgpm3, p.gravity_mps2,
        std::sqrt(2.0 * p.mass_kg * p.gravity_mps2 / drag), p.table_max_height_m, t,
        kMaxFallTimeS));
  }
  // The spec integrates with RK4 at a fixed 0.01 s. Drag that brakes the
  // body faster than that (a light body with a large area) makes the
  // integration unstable: garbage, or NaN, instead of a fall. Realistic
  // aircraft are two orders of magnitude away (default: 0.002).
  const double drag_per_mass =
      0.5 * p.air_density_kgpm3 * p.drag_coefficient * p.frontal_area_m2 / p.mass_kg;
  if (drag_per_mass > 0.0) {
    const double terminal_mps = std::sqrt(p.gravity_mps2 / drag_per_mass);
    const double rate = drag_per_mass * std::max(p.airspeed_mps, terminal_mps);
    if (rate * kBallisticStepS > 1.0) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "parameters 'mass_kg' (%g), 'drag_coefficient' (%g), 'frontal_area_m2' (%g), "
          "'air_density_kgpm3' (%g) and 'airspeed_mps' (%g) brake the fall with a time "
          "constant of %.3g s; the ballistic integration's fixed step of %g s cannot follow "
          "one under it",
          p.mass_kg, p.drag_coefficient, p.frontal_area_m2, p.air_density_kgpm3, p.airspeed_mps,
          1.0 / rate, kBallisticStepS));
    }
  }
  return absl::OkStatus();
}

bool SameKernelParams(const ModelParams& a, const ModelParams& b) {
  return a.mass_kg == b.mass_kg && a.drag_coefficient == b.drag_coefficient &&
         a.frontal_area_m2 == b.frontal_area_m2 && a.airspeed_mps == b.airspeed_mps &&
         a.uav_radius_m == b.uav_radius_m && a.gravity_mps2 == b.gravity_mps2 &&
         a.air_density_kgpm3 == b.air_density_kgpm3 && a.person_radius_m == b.person_radius_m &&
         a.person_height_m == b.person_height_m && a.alpha_j == b.alpha_j && a.beta_j == b.beta_j &&
         a.sigma_pos_m == b.sigma_pos_m && a.sigma_speed_mps == b.sigma_speed_mps &&
         a.sigma_wind_mps == b.sigma_wind_mps && a.heading_bins == b.heading_bins &&
         a.height_bin_m == b.height_bin_m && a.table_max_height_m == b.table_max_height_m &&
         a.max_half_width == b.max_half_width;
}

bool SameImpactTableParams(const ModelParams& a, const ModelParams& b) {
  return SameKernelParams(a, b) && a.wind_speed_mps == b.wind_speed_mps &&
         (a.Calm() || a.wind_from_deg == b.wind_from_deg);
}

bool SameGlideParams(const ModelParams& a, const ModelParams& b) {
  if (a.glide_ratio != b.glide_ratio || a.glide_clearance_m != b.glide_clearance_m) return false;
  // In still air the glide does not depend on its airspeed (spec section 6).
  if (a.Calm() && b.Calm()) return true;
  return a.wind_speed_mps == b.wind_speed_mps && a.wind_from_deg == b.wind_from_deg &&
         a.GlideAirspeed() == b.GlideAirspeed();
}

double ModelParams::GroundTurnRadius() const {
  if (Calm()) return turn_radius_m;
  const double f = 1.0 + wind_speed_mps / airspeed_mps;
  return turn_radius_m * f * f;
}

double ModelParams::GroundClimbAngle() const {
  if (Calm()) return max_climb_rad;
  return std::atan(std::tan(max_climb_rad) * airspeed_mps / (airspeed_mps + wind_speed_mps));
}

}  // namespace riskplan
