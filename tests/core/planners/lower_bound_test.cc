// The lower bound (core/planners/lower_bound.h): never above the risk of any
// route a planner returns on the test scenarios (every planner, the lattice,
// still air and wind), positive across a city, and its options checked.
#include "core/planners/lower_bound.h"

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "core/planners/state_lattice.h"
#include "gtest/gtest.h"
#include "tests/core/planner_test_util.h"

namespace riskplan {
namespace {

using testing_planner::FindFlyablePose;
using testing_planner::ReEvaluate;

// The 2 km city, the wind (if any) from 100°.
std::shared_ptr<const RiskModel> SmallCity(double wind_mps) {
  return testing_planner::SmallCityModel(wind_mps, 100.0);
}

TEST(LowerBoundTest, NeverAboveAnyPlannersRoute) {
  const double raw[][6] = {{300, 1000, 0, 1700, 1000, 0},
                           {1000, 300, 1.57, 1000, 1700, 1.57},
                           {400, 400, 0.78, 1600, 1500, 0.78},
                           {900, 900, 0, 1100, 1000, 3.14}};
  for (double wind : {0.0, 7.0}) {
    SCOPED_TRACE(wind);
    auto model = SmallCity(wind);
    auto bound = RiskLowerBound::Build(model, LowerBoundOptions{});
    ASSERT_TRUE(bound.ok()) << bound.status();
    LatticeOptions lo;
    lo.spacing_m = 200.0;
    auto lattice = StateLattice::Create(*model, lo);
    ASSERT_TRUE(lattice.ok());
    DirectRiskEvaluator evaluator;
    int checked = 0;
    for (const auto& r : raw) {
      auto s = FindFlyablePose(*model, r[0], r[1], r[2]);
      auto g = FindFlyablePose(*model, r[3], r[4], r[5]);
      ASSERT_TRUE(s && g);
      SCOPED_TRACE(r[0]);
      const double lb = (*bound)->Query(*s, *g);
      EXPECT_GE(lb, 0.0);
      std::vector<std::vector<Pose>> routes;
      auto lat = (*lattice)->Solve(*s, *g, &evaluator);
      ASSERT_TRUE(lat.ok());
      if (lat->has_value()) routes.push_back((*lat)->waypoints);
      struct Run {
        PlannerAlgorithm algorithm;
        int64_t iterations;
        std::map<std::string, double> params;
      };
      const Run runs[] = {
          {PlannerAlgorithm::kRiskRrtStar, 300, {}},
          {PlannerAlgorithm::kRiskRrtStar, 300, {{"guide", 1.0}, {"guide_field_m", 200.0}}},
          {PlannerAlgorithm::kRrt, 2000, {}},
          {PlannerAlgorithm::kGenetic, 10, {}},
          {PlannerAlgorithm::kHarmonic, 200, {}}};
      for (const Run& run : runs) {
        auto planner = MakePlanner(run.algorithm);
        ASSERT_TRUE(planner.ok());
        PlanOptions options;
        options.budget.max_time_s = 0.0;
        options.budget.max_iterations = run.iterations;
        options.seed = 3;
        options.params = run.params;
        CancellationToken cancel;
        auto result = (*planner)->Plan({model, *s, *g}, options, cancel, nullptr);
        ASSERT_TRUE(result.ok()) << result.status();
        if (result->best.has_value()) routes.push_back(result->best->waypoints);
      }
      for (const std::vector<Pose>& w : routes) {
        bool admissible = false;
        const double risk = ReEvaluate(*model, w, &admissible);
        if (!admissible) continue;
        EXPECT_LE(lb, risk);
        ++checked;
      }
      // Across the small city the bound is not the trivial 0.
      if (std::hypot(g->x - s->x, g->y - s->y) > 1000.0) {
        EXPECT_GT(lb, 0.0);
      }
    }
    EXPECT_GE(checked, 12);
  }
}

TEST(LowerBoundTest, BadOptionsNameTheirField) {
  auto model = SmallCity(0.0);
  LowerBoundOptions o;
  o.block_m = 1.0;
  EXPECT_NE(RiskLowerBound::Build(model, o).status().message().find("block_m"), std::string::npos);
  o = LowerBoundOptions{};
  o.ring = 1;
  EXPECT_NE(RiskLowerBound::Build(model, o).status().message().find("ring"), std::string::npos);
}

}  // namespace
}  // namespace riskplan
