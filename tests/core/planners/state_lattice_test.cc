// The state lattice (core/planners/state_lattice.h): its routes are
// admissible and their risk is EvaluateTrajectory's bit for bit, in still
// air and in wind; a full field gives the same optimum as the search that
// stops early; bad options are refused by name.
#include "core/planners/state_lattice.h"

#include <cmath>
#include <memory>
#include <vector>

#include "gtest/gtest.h"
#include "tests/core/planner_test_util.h"

namespace riskplan {
namespace {

using testing_planner::FindFlyablePose;
using testing_planner::ReEvaluate;

// demo-city at 2 km (the same city scaled), with `wind_mps` from 240 degrees.
// The 2 km city, the wind (if any) from 240°.
std::shared_ptr<const RiskModel> SmallCity(double wind_mps = 0.0) {
  return testing_planner::SmallCityModel(wind_mps, 240.0);
}

struct Pair {
  Pose start;
  Pose goal;
};

std::vector<Pair> Pairs(const RiskModel& model) {
  const double raw[][6] = {{300, 1000, 0, 1700, 1000, 0},
                           {1000, 300, 1.57, 1000, 1700, 1.57},
                           {400, 400, 0.78, 1600, 1500, 0.78},
                           {900, 900, 0, 1100, 1000, 3.14}};
  std::vector<Pair> out;
  for (const auto& r : raw) {
    auto s = FindFlyablePose(model, r[0], r[1], r[2]);
    auto g = FindFlyablePose(model, r[3], r[4], r[5]);
    EXPECT_TRUE(s.has_value() && g.has_value());
    if (s && g) out.push_back({*s, *g});
  }
  return out;
}

LatticeOptions Coarse() {
  LatticeOptions o;
  o.spacing_m = 200.0;
  o.headings = 8;
  return o;
}

TEST(StateLatticeTest, RouteIsAdmissibleAndItsRiskIsEvaluateTrajectorysBitForBit) {
  for (double wind : {0.0, 6.0}) {
    SCOPED_TRACE(wind);
    auto model = SmallCity(wind);
    auto lattice = StateLattice::Create(*model, Coarse());
    ASSERT_TRUE(lattice.ok()) << lattice.status();
    DirectRiskEvaluator evaluator;
    for (const Pair& p : Pairs(*model)) {
      auto route = (*lattice)->Solve(p.start, p.goal, &evaluator);
      ASSERT_TRUE(route.ok()) << route.status();
      ASSERT_TRUE(route->has_value());
      const std::vector<Pose>& w = (*route)->waypoints;
      ASSERT_GE(w.size(), 2u);
      EXPECT_EQ(w.front().x, p.start.x);
      EXPECT_EQ(w.back().y, p.goal.y);
      bool admissible = false;
      const double risk = ReEvaluate(*model, w, &admissible);
      EXPECT_TRUE(admissible);
      EXPECT_EQ(risk, (*route)->risk);
      EXPECT_GT(risk, 0.0);
    }
  }
}

TEST(StateLatticeTest, FieldRouteHasTheSearchsOptimum) {
  auto model = SmallCity();
  auto lattice = StateLattice::Create(*model, Coarse());
  ASSERT_TRUE(lattice.ok());
  DirectRiskEvaluator evaluator;
  const Pair p = Pairs(*model)[2];
  auto solved = (*lattice)->Solve(p.start, p.goal, &evaluator);
  auto field = (*lattice)->Field(p.goal, &evaluator);
  ASSERT_TRUE(solved.ok() && field.ok());
  auto down = (*lattice)->RouteDown(*model, *field, p.start, &evaluator);
  ASSERT_TRUE(down.ok() && down->has_value() && solved->has_value());
  EXPECT_NEAR((*down)->risk, (*solved)->risk, 1e-12 * (*solved)->risk);
  // The same problem twice: the same route.
  auto again = (*lattice)->Solve(p.start, p.goal, &evaluator);
  ASSERT_TRUE(again.ok() && again->has_value());
  EXPECT_EQ((*again)->risk, (*solved)->risk);
  EXPECT_EQ((*again)->waypoints.size(), (*solved)->waypoints.size());
}

TEST(StateLatticeTest, FinerLatticeRouteIsExactToo) {
  auto model = SmallCity();
  LatticeOptions fine = Coarse();
  fine.spacing_m = 100.0;
  fine.headings = 16;
  auto lattice = StateLattice::Create(*model, fine);
  ASSERT_TRUE(lattice.ok());
  DirectRiskEvaluator evaluator;
  const Pair p = Pairs(*model)[0];
  auto route = (*lattice)->Solve(p.start, p.goal, &evaluator);
  ASSERT_TRUE(route.ok() && route->has_value());
  bool admissible = false;
  EXPECT_EQ(ReEvaluate(*model, (*route)->waypoints, &admissible), (*route)->risk);
  EXPECT_TRUE(admissible);
}

TEST(StateLatticeTest, BadOptionsNameTheirField) {
  auto model = SmallCity();
  LatticeOptions o = Coarse();
  o.spacing_m = 1.0;
  EXPECT_NE(StateLattice::Create(*model, o).status().message().find("spacing_m"),
            std::string::npos);
  o = Coarse();
  o.headings = 2;
  EXPECT_NE(StateLattice::Create(*model, o).status().message().find("headings"), std::string::npos);
  o = Coarse();
  o.level_offsets_m = {3.0, -1.0};
  EXPECT_NE(StateLattice::Create(*model, o).status().message().find("level_offsets_m[1]"),
            std::string::npos);
  o = Coarse();
  o.risk_step_m = std::nan("");
  EXPECT_NE(StateLattice::Create(*model, o).status().message().find("risk_step_m"),
            std::string::npos);
}

}  // namespace
}  // namespace riskplan
