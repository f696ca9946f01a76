// Shared set-up for planner tests on demo-city.
#ifndef RISKPLAN_TESTS_CORE_PLANNER_TEST_UTIL_H_
#define RISKPLAN_TESTS_CORE_PLANNER_TEST_UTIL_H_

#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <vector>

#include "bench/scenarios.h"
#include "core/map/demo_city.h"
#include "core/planners/planner.h"
#include "core/risk/risk_model.h"
#include "gtest/gtest.h"

namespace riskplan::testing_planner {

using bench::FindFlyablePose;
using bench::FlyablePose;
using bench::Scenario;

// demo-city with default parameters, built once per test program.
inline std::shared_ptr<const RiskModel> DemoCityModel() {
  static std::shared_ptr<const RiskModel> model = [] {
    auto map = MakeDemoCity();
    EXPECT_TRUE(map.ok()) << map.status();
    auto m = RiskModel::Create(*map, ModelParams{});
    EXPECT_TRUE(m.ok()) << m.status();
    return *m;
  }();
  return model;
}

// The shared scenario set (bench/scenarios.h), with every pose found.
inline std::vector<Scenario> DemoCityScenarios(const RiskModel& model) {
  std::vector<Scenario> out = bench::DemoCityScenarios(model);
  EXPECT_GE(out.size(), 24u);
  return out;
}

}  // namespace riskplan::testing_planner

#endif  // RISKPLAN_TESTS_CORE_PLANNER_TEST_UTIL_H_
