#include "core/base/model_params.h"

#include <cmath>

#include "absl/strings/str_format.h"

namespace riskplan {
namespace {

// Accepts [lo, hi] (both inclusive) and finite values only.
absl::Status CheckRange(const char* name, double value, double lo, double hi) {
  if (!std::isfinite(value) || value < lo || value > hi) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "parameter '%s' has value %g; it must be finite and in [%g, %g]", name, value, lo, hi));
  }
  return absl::OkStatus();
}

// Accepts (lo, hi]: strictly positive quantities.
absl::Status CheckPositive(const char* name, double value, double hi) {
  if (!std::isfinite(value) || value <= 0.0 || value > hi) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "parameter '%s' has value %g; it must be finite and in (0, %g]", name, value, hi));
  }
  return absl::OkStatus();
}

struct FieldRef {
  std::string_view name;
  double ModelParams::*real = nullptr;
  int ModelParams::*integer = nullptr;
};

// One table for SetModelParam, GetModelParam and ModelParamNames, so that a new
// field needs one line here.
const std::vector<FieldRef>& Fields() {
  static const auto* fields = new std::vector<FieldRef>{
      {"mass_kg", &ModelParams::mass_kg},
      {"drag_coefficient", &ModelParams::drag_coefficient},
      {"frontal_area_m2", &ModelParams::frontal_area_m2},
      {"airspeed_mps", &ModelParams::airspeed_mps},
      {"uav_radius_m", &ModelParams::uav_radius_m},
      {"turn_radius_m", &ModelParams::turn_radius_m},
      {"max_climb_rad", &ModelParams::max_climb_rad},
      {"failure_rate_per_s", &ModelParams::failure_rate_per_s},
      {"gravity_mps2", &ModelParams::gravity_mps2},
      {"air_density_kgpm3", &ModelParams::air_density_kgpm3},
      {"person_radius_m", &ModelParams::person_radius_m},
      {"person_height_m", &ModelParams::person_height_m},
      {"alpha_j", &ModelParams::alpha_j},
      {"beta_j", &ModelParams::beta_j},
      {"sigma_pos_m", &ModelParams::sigma_pos_m},
      {"sigma_speed_mps", &ModelParams::sigma_speed_mps},
      {"sigma_wind_mps", &ModelParams::sigma_wind_mps},
      {"heading_bins", nullptr, &ModelParams::heading_bins},
      {"height_bin_m", &ModelParams::height_bin_m},
      {"table_max_height_m", &ModelParams::table_max_height_m},
      {"max_half_width", nullptr, &ModelParams::max_half_width},
      {"sample_step_m", &ModelParams::sample_step_m},
      {"min_agl_m", &ModelParams::min_agl_m},
      {"max_agl_m", &ModelParams::max_agl_m},
      {"glide_ratio", &ModelParams::glide_ratio},
      {"glide_clearance_m", &ModelParams::glide_clearance_m},
  };
  return *fields;
}

}  // namespace

absl::Status SetModelParam(ModelParams* params, std::string_view name, double value) {
  for (const FieldRef& f : Fields()) {
    if (f.name != name) continue;
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
    if (f.name != name) continue;
    return f.real != nullptr ? params.*f.real : static_cast<double>(params.*f.integer);
  }
  return absl::NotFoundError(absl::StrFormat("unknown model parameter '%s'", std::string(name)));
}

const std::vector<std::string_view>& ModelParamNames() {
  static const auto* names = [] {
    auto* v = new std::vector<std::string_view>;
    for (const FieldRef& f : Fields()) v->push_back(f.name);
    return v;
  }();
  return *names;
}

int ModelParams::HeightBins() const {
  return static_cast<int>(std::lround(table_max_height_m / height_bin_m));
}

absl::Status ValidateModelParams(const ModelParams& p) {
  // The upper limits are generous physical bounds for a small fixed-wing UAV;
  // they exist so that a typo cannot make the impact table or a kernel huge.
  const absl::Status checks[] = {
      CheckPositive("mass_kg", p.mass_kg, 1000.0),
      CheckRange("drag_coefficient", p.drag_coefficient, 0.0, 10.0),
      CheckRange("frontal_area_m2", p.frontal_area_m2, 0.0, 100.0),
      CheckPositive("airspeed_mps", p.airspeed_mps, 200.0),
      CheckRange("uav_radius_m", p.uav_radius_m, 0.0, 50.0),
      CheckPositive("turn_radius_m", p.turn_radius_m, 10000.0),
      CheckPositive("max_climb_rad", p.max_climb_rad, 1.4),
      CheckRange("failure_rate_per_s", p.failure_rate_per_s, 0.0, 1.0),
      CheckPositive("gravity_mps2", p.gravity_mps2, 100.0),
      CheckRange("air_density_kgpm3", p.air_density_kgpm3, 0.0, 10.0),
      CheckRange("person_radius_m", p.person_radius_m, 0.0, 10.0),
      CheckRange("person_height_m", p.person_height_m, 0.0, 10.0),
      CheckPositive("alpha_j", p.alpha_j, 1e12),
      CheckPositive("beta_j", p.beta_j, 1e12),
      CheckRange("sigma_pos_m", p.sigma_pos_m, 0.0, 1000.0),
      CheckRange("sigma_speed_mps", p.sigma_speed_mps, 0.0, 100.0),
      CheckRange("sigma_wind_mps", p.sigma_wind_mps, 0.0, 100.0),
      CheckRange("heading_bins", p.heading_bins, 1, 3600),
      CheckPositive("height_bin_m", p.height_bin_m, 1000.0),
      CheckPositive("table_max_height_m", p.table_max_height_m, 5000.0),
      CheckRange("max_half_width", p.max_half_width, 0, 63),
      CheckPositive("sample_step_m", p.sample_step_m, 1000.0),
      CheckRange("min_agl_m", p.min_agl_m, 0.0, 10000.0),
      CheckPositive("max_agl_m", p.max_agl_m, 10000.0),
      CheckPositive("glide_ratio", p.glide_ratio, 1000.0),
      CheckRange("glide_clearance_m", p.glide_clearance_m, 0.0, 1000.0),
  };
  for (const absl::Status& s : checks) {
    if (!s.ok()) return s;
  }
  // Gaussian dispersion needs a non-degenerate covariance.
  if (p.sigma_pos_m <= 0.0 && p.sigma_wind_mps <= 0.0) {
    return absl::InvalidArgumentError(
        "parameters 'sigma_pos_m' and 'sigma_wind_mps' are both 0; the impact dispersion "
        "across the heading would be degenerate");
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
  return absl::OkStatus();
}

bool SameImpactTableParams(const ModelParams& a, const ModelParams& b) {
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

bool SameGlideParams(const ModelParams& a, const ModelParams& b) {
  return a.glide_ratio == b.glide_ratio && a.glide_clearance_m == b.glide_clearance_m;
}

}  // namespace riskplan
