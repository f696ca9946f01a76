// The parameters of the ground-risk model and of the aircraft.
//
// Defaults are exactly the table "Default parameters" of shared/spec/risk-model.md.
// Every field may be overridden per request; ValidateModelParams() says which
// values are usable.
#ifndef RISKPLAN_CORE_BASE_MODEL_PARAMS_H_
#define RISKPLAN_CORE_BASE_MODEL_PARAMS_H_

#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace riskplan {

struct ModelParams {
  // Aircraft.
  double mass_kg = 10.0;                    // m
  double drag_coefficient = 0.8;            // c_d, ballistic
  double frontal_area_m2 = 0.2;             // A_f, in ballistic fall
  double airspeed_mps = 18.0;               // v, cruise (no wind: ground speed)
  double uav_radius_m = 1.0;                // r_uav
  double turn_radius_m = 50.0;              // R, minimum turning radius
  double max_climb_rad = 0.15;              // gamma_max, climb or descent
  double failure_rate_per_s = 5e-3 / 3600;  // lambda (5e-3 per flight hour)

  // Physics.
  double gravity_mps2 = 9.81;
  double air_density_kgpm3 = 1.225;

  // Casualty model.
  double person_radius_m = 0.3;  // r_p
  double person_height_m = 1.8;  // h_p
  double alpha_j = 1e6;          // alpha
  double beta_j = 100.0;         // beta

  // Impact dispersion.
  double sigma_pos_m = 5.0;
  double sigma_speed_mps = 2.0;
  double sigma_wind_mps = 2.0;

  // Impact table discretisation.
  int heading_bins = 72;              // N_theta
  double height_bin_m = 5.0;          // Delta h
  double table_max_height_m = 300.0;  // h_table_max (a multiple of height_bin_m)
  int max_half_width = 31;            // hw_max: kernel at most 63 x 63 cells

  // Trajectory sampling and flight band.
  double sample_step_m = 5.0;  // d_step
  double min_agl_m = 30.0;
  double max_agl_m = 150.0;

  // Safe-altitude map (emergency glide to a landing site).
  double glide_ratio = 10.0;        // G
  double glide_clearance_m = 10.0;  // clearance over terrain during a glide

  // Mean wind (spec version 3, section 0): its speed W and the direction it
  // blows FROM, in degrees clockwise from the map's north (meteorological);
  // any finite direction is taken modulo 360.
  double wind_speed_mps = 0.0;
  double wind_from_deg = 0.0;
  // v_g, the airspeed of the emergency glide (spec section 6); 0 means the
  // cruise airspeed v (the spec's default, v_g = v).
  double glide_airspeed_mps = 0.0;

  // Number of height bins of the impact table: h_table_max / Delta h.
  int HeightBins() const;

  // True when there is no wind (W = 0): every number is version 2's.
  bool Calm() const { return wind_speed_mps == 0.0; }
  // v_g: glide_airspeed_mps, or airspeed_mps when that is 0.
  double GlideAirspeed() const { return glide_airspeed_mps > 0.0 ? glide_airspeed_mps : airspeed_mps; }
  // The Dubins-airplane radius and climb angle over the ground (spec section
  // 5): R_w = R (1 + W/v)^2 and gamma_w = atan(tan(gamma_max) v / (v + W));
  // exactly turn_radius_m and max_climb_rad when Calm().
  double GroundTurnRadius() const;
  double GroundClimbAngle() const;
};

// The range riskplan accepts for one parameter, [min_value, max_value]
// (both inclusive), and why. The bounds are physical (what a small
// fixed-wing UAV, a person or a planet can be) and keep every quantity the
// model computes finite and every loop it runs bounded: docs/api.md prints
// this table, and a test checks that it agrees with the code.
struct ModelParamRange {
  std::string_view name;
  double min_value = 0.0;
  double max_value = 0.0;
  bool integer = false;  // whole numbers only
  std::string_view why;
};

// Every parameter's range, in declaration order.
const std::vector<ModelParamRange>& ModelParamRanges();

// The rules between parameters that ValidateModelParams checks after the
// ranges, one sentence each (docs/api.md lists them).
const std::vector<std::string_view>& ModelParamRules();

// Returns OK when every field is finite and inside its range
// (ModelParamRanges) and the parameters together obey ModelParamRules,
// else InvalidArgument naming the first offending field (or fields), its
// value and the limit, e.g. "parameter 'beta_j' has value 5e-324; it must be
// finite and in [1, 1e+12]".
absl::Status ValidateModelParams(const ModelParams& params);

// The fixed step of the ballistic integration (spec section 1), s.
inline constexpr double kBallisticStepS = 0.01;
// Longest fall the impact table simulates, s (kMaxBallisticSteps steps of
// kBallisticStepS).
inline constexpr double kMaxFallTimeS = 10000.0;

// A lower bound of the time of a ballistic fall from `height_m` (spec
// section 1): max(h / v_t, sqrt(2 h / g)), with the terminal velocity
// v_t = sqrt(2 m g / (rho_air c_d A_f)) (infinite without drag). Never more
// than the simulated fall time, so a parameter set whose bound exceeds
// kMaxFallTimeS is refused before anything is integrated.
double FallTimeLowerBound(double height_m, const ModelParams& params);

// Sets the field called `name` (the field names above, e.g. "mass_kg") to
// `value`. Integer fields take integral values only. Returns InvalidArgument for
// an unknown name or a non-integral value for an integer field; the range is
// checked by ValidateModelParams().
absl::Status SetModelParam(ModelParams* params, std::string_view name, double value);

// Reads the field called `name`; NotFound for an unknown name.
absl::StatusOr<double> GetModelParam(const ModelParams& params, std::string_view name);

// Every settable field name, in declaration order.
const std::vector<std::string_view>& ModelParamNames();

// True when the two parameter sets give the same impact table for the same map
// resolution (every field the table depends on is equal).
bool SameImpactTableParams(const ModelParams& a, const ModelParams& b);

// True when the two parameter sets give the same kernel weights, dispersions
// and falls (SameImpactTableParams but for the wind, which moves only the
// kernels' offsets, energies and angles): a table in one wind can share the
// weights of a table in another.
bool SameKernelParams(const ModelParams& a, const ModelParams& b);

// The largest wind the model accepts relative to the airspeed (spec:
// 0 <= W <= 0.5 v, so that every ground speed is at least v / 2).
inline constexpr double kMaxWindFraction = 0.5;

// True when the two parameter sets give the same glide-altitude layer.
bool SameGlideParams(const ModelParams& a, const ModelParams& b);

}  // namespace riskplan

#endif  // RISKPLAN_CORE_BASE_MODEL_PARAMS_H_
