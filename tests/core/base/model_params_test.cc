#include "core/base/model_params.h"

#include <cmath>
#include <limits>
#include <string>

#include "absl/strings/str_format.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace riskplan {
namespace {

using ::testing::HasSubstr;

// The message ValidateModelParams gives for `name` out of its range.
std::string RangeError(const ModelParamRange& r, double value) {
  return absl::StrFormat("parameter '%s' has value %g; it must be finite and in [%g, %g]",
                         std::string(r.name), value, r.min_value, r.max_value);
}

TEST(ModelParamRangesTest, DefaultsAreInsideEveryRange) {
  EXPECT_TRUE(ValidateModelParams(ModelParams{}).ok());
  ASSERT_EQ(ModelParamRanges().size(), ModelParamNames().size());
  for (const ModelParamRange& r : ModelParamRanges()) {
    const double value = *GetModelParam(ModelParams{}, r.name);
    EXPECT_GE(value, r.min_value) << r.name;
    EXPECT_LE(value, r.max_value) << r.name;
    EXPECT_FALSE(r.why.empty()) << r.name;
  }
}

// Each bound at, just inside and just outside: at and inside pass the range
// check (another rule may still refuse the set, never with this parameter's
// range message); outside is refused with the value and the range.
TEST(ModelParamRangesTest, EveryBoundAtInsideAndOutside) {
  for (const ModelParamRange& r : ModelParamRanges()) {
    const double step = r.integer ? 1.0 : 0.0;
    const auto nudge = [&](double v, double towards) {
      return r.integer ? v + (towards > v ? step : -step) : std::nextafter(v, towards);
    };
    const double inf = std::numeric_limits<double>::infinity();
    for (const double bound : {r.min_value, r.max_value}) {
      const double inside = nudge(bound, bound == r.min_value ? inf : -inf);
      const double outside = nudge(bound, bound == r.min_value ? -inf : inf);
      for (const double ok : {bound, inside}) {
        ModelParams p;
        ASSERT_TRUE(SetModelParam(&p, r.name, ok).ok()) << r.name;
        const absl::Status s = ValidateModelParams(p);
        EXPECT_THAT(std::string(s.message()),
                    ::testing::Not(HasSubstr(
                        absl::StrFormat("parameter '%s' has value", std::string(r.name)))))
            << r.name << " = " << ok;
      }
      ModelParams p;
      ASSERT_TRUE(SetModelParam(&p, r.name, outside).ok()) << r.name;
      const absl::Status s = ValidateModelParams(p);
      EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << r.name << " = " << outside;
      EXPECT_EQ(s.message(), RangeError(r, outside)) << r.name;
    }
    ModelParams nan;
    if (!r.integer) {
      ASSERT_TRUE(SetModelParam(&nan, r.name, std::nan("")).ok());
      EXPECT_EQ(ValidateModelParams(nan).message(), RangeError(r, std::nan(""))) << r.name;
    }
  }
}

// The values an adversarial client sent, each inside the old documented
// ranges, and what they did before.
TEST(ModelParamRangesTest, TheIssuesValuesAreRefusedNamingFieldValueAndRange) {
  struct Case {
    const char* name;
    double value;
    const char* message;
  };
  const Case cases[] = {
      // 0 samples, then a sample count that overflowed int.
      {"sample_step_m", 1e-7,
       "parameter 'sample_step_m' has value 1e-07; it must be finite and in [0.1, 1000]"},
      // A spiral of 2^31 turns wrapped to one: a 0.32 rad climb admitted.
      {"turn_radius_m", 1e-9,
       "parameter 'turn_radius_m' has value 1e-09; it must be finite and in [1, 10000]"},
      // The ballistic integration ran to its step cap for every height bin.
      {"gravity_mps2", 1e-300,
       "parameter 'gravity_mps2' has value 1e-300; it must be finite and in [0.1, 30]"},
      {"mass_kg", 1e-300,
       "parameter 'mass_kg' has value 1e-300; it must be finite and in [0.01, 1000]"},
      // Risk NaN: sqrt(alpha / beta) infinite times 0.
      {"beta_j", 5e-324,
       "parameter 'beta_j' has value 4.94066e-324; it must be finite and in [1, 1e+12]"},
      // Pieces of 1e14 m for GENETIC.
      {"max_climb_rad", 1e-12,
       "parameter 'max_climb_rad' has value 1e-12; it must be finite and in [0.01, 1.4]"},
  };
  for (const Case& c : cases) {
    ModelParams p;
    ASSERT_TRUE(SetModelParam(&p, c.name, c.value).ok());
    const absl::Status s = ValidateModelParams(p);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << c.name;
    EXPECT_EQ(s.message(), c.message);
  }
}

// The fall-time rule: a body whose terminal velocity makes the fall from
// table_max_height_m longer than kMaxFallTimeS is refused before anything is
// integrated; the bound is checked at, just under and just over. (A slow
// fall needs weak gravity: a draggier body is refused by the next rule.)
TEST(ModelParamRulesTest, FallTimeLowerBoundAtUnderAndOver) {
  ModelParams p;
  p.gravity_mps2 = 0.1;
  p.airspeed_mps = 1.0;
  p.air_density_kgpm3 = 10.0;
  p.drag_coefficient = 2.0;
  p.frontal_area_m2 = 1.0;
  p.mass_kg = 0.2;  // k = 50 per m, terminal velocity sqrt(0.1 / 50) m/s
  const double terminal = std::sqrt(p.gravity_mps2 / 50.0);
  // One height bin at h = t v_t.
  const auto height_for = [&](double t) { p.table_max_height_m = p.height_bin_m = t * terminal; };
  height_for(kMaxFallTimeS * 0.999);  // just under
  EXPECT_LT(FallTimeLowerBound(p.table_max_height_m, p), kMaxFallTimeS);
  EXPECT_TRUE(ValidateModelParams(p).ok()) << ValidateModelParams(p);
  height_for(kMaxFallTimeS);
  EXPECT_NEAR(FallTimeLowerBound(p.table_max_height_m, p), kMaxFallTimeS, 1e-6);
  height_for(kMaxFallTimeS * 1.001);  // just over
  const absl::Status s = ValidateModelParams(p);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(s.message()),
              HasSubstr("give a terminal velocity of 0.0447 m/s: a fall from "
                        "'table_max_height_m' (447.661 m) lasts at least 1e+04 s; at most 10000 s "
                        "of fall is simulated"));
  EXPECT_THAT(std::string(s.message()), HasSubstr("'mass_kg' (0.2)"));
}

// The stiffness rule: drag whose time constant is under the integration's
// 0.01 s step is refused (RK4 would blow up), at, just under and just over.
TEST(ModelParamRulesTest, DragTimeConstantAtUnderAndOver) {
  ModelParams p;
  p.air_density_kgpm3 = 10.0;
  p.drag_coefficient = 2.0;
  p.frontal_area_m2 = 1.0;
  p.airspeed_mps = 20.0;
  // k v dt = (10 / m) 20 0.01 = 2 / m: 1 at m = 2.
  p.mass_kg = 2.0 * 1.001;
  EXPECT_TRUE(ValidateModelParams(p).ok()) << ValidateModelParams(p);
  p.mass_kg = 2.0;
  EXPECT_TRUE(ValidateModelParams(p).ok()) << ValidateModelParams(p);
  p.mass_kg = 2.0 * 0.999;
  const absl::Status s = ValidateModelParams(p);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(s.message()),
              HasSubstr("'airspeed_mps' (20) brake the fall with a time constant of 0.00999 s; "
                        "the ballistic integration's fixed step of 0.01 s cannot follow one "
                        "under it"));
}

TEST(ModelParamRulesTest, FallTimeLowerBoundIsFreeFallWithoutDrag) {
  ModelParams p;
  p.drag_coefficient = 0.0;
  EXPECT_DOUBLE_EQ(FallTimeLowerBound(500.0, p), std::sqrt(2.0 * 500.0 / p.gravity_mps2));
  EXPECT_EQ(FallTimeLowerBound(0.0, p), 0.0);
}

TEST(ModelParamRulesTest, EveryRuleIsListed) {
  EXPECT_EQ(ModelParamRules().size(), 6u);
  ModelParams p;
  p.alpha_j = p.beta_j;
  EXPECT_THAT(std::string(ValidateModelParams(p).message()), HasSubstr("'alpha_j'"));
  p = ModelParams{};
  p.max_agl_m = p.min_agl_m;
  EXPECT_THAT(std::string(ValidateModelParams(p).message()), HasSubstr("'max_agl_m'"));
  p = ModelParams{};
  p.table_max_height_m = 303.0;
  EXPECT_THAT(std::string(ValidateModelParams(p).message()), HasSubstr("a multiple"));
  // Version 3: the wind is at most half the airspeed.
  p = ModelParams{};
  p.wind_speed_mps = 9.5;
  EXPECT_THAT(std::string(ValidateModelParams(p).message()),
              HasSubstr("'wind_speed_mps' (9.5) must be at most 0.5 times 'airspeed_mps' (18)"));
}

}  // namespace
}  // namespace riskplan
