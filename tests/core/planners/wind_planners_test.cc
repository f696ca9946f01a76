// Every planner in a wind (risk model version 3): its trajectories are
// admissible in that wind and their risks are EvaluateTrajectory's with the
// same wind, bit for bit; the wind changes what is planned; the guide route
// weights each step by its time over the ground.
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "core/base/wind.h"
#include "core/planners/planner.h"
#include "core/planners/risk_guide.h"
#include "core/risk/risk_evaluator.h"
#include "gtest/gtest.h"
#include "tests/core/obstacle_test_maps.h"
#include "tests/core/planner_test_util.h"
#include "tests/core/seed_planner_test_util.h"

namespace riskplan {
namespace {

using testing_planner::Outcome;
using testing_planner::RunPlan;
using testing_planner::Scenario;

// demo-city's default model in a wind of `speed` m/s from `from_deg`, its
// table made from the default one (RiskModel::Create's InWind).
std::shared_ptr<const RiskModel> InWind(const std::shared_ptr<const RiskModel>& calm, double speed,
                                        double from_deg) {
  ModelParams p = calm->params();
  p.wind_speed_mps = speed;
  p.wind_from_deg = from_deg;
  auto model = RiskModel::Create(calm->map_ptr(), p, calm->table_ptr());
  EXPECT_TRUE(model.ok()) << model.status();
  return *model;
}

struct WindCase {
  const char* name;
  double from_deg;
};
constexpr WindCase kWinds[] = {{"8 m/s from the west", 270.0}, {"8 m/s from the north", 0.0}};

struct PlannerCase {
  PlannerAlgorithm algorithm;
  int64_t iterations;
  bool risk_ordered;
};
constexpr PlannerCase kPlanners[] = {
    {PlannerAlgorithm::kRiskRrtStar, 1500, true},
    {PlannerAlgorithm::kRrt, 20000, true},
    {PlannerAlgorithm::kGenetic, 40, false},
    {PlannerAlgorithm::kHarmonic, 20000, true},
};

class WindPlannersTest : public testing_planner::DemoCityPlannerTest {
 protected:
  const Scenario& Find(const std::string& name) {
    for (const Scenario& s : scenarios_) {
      if (name == s.name) return s;
    }
    ADD_FAILURE() << "no scenario " << name;
    return scenarios_.front();
  }
};

TEST_F(WindPlannersTest, EveryPlannerIsAdmissibleAndExactInTheWind) {
  const Scenario& sc = Find("5km-a");
  for (const WindCase& w : kWinds) {
    SCOPED_TRACE(w.name);
    const auto wind = InWind(model_, 8.0, w.from_deg);
    ASSERT_FALSE(wind->wind().calm());
    for (const PlannerCase& pc : kPlanners) {
      SCOPED_TRACE(std::string(PlannerAlgorithmName(pc.algorithm)));
      // The scenario's poses are found in still air; in this wind they must
      // still be flyable for the test to mean something.
      ASSERT_EQ(wind->CheckConfiguration(sc.start), ViolationKind::kNone);
      ASSERT_EQ(wind->CheckConfiguration(sc.goal), ViolationKind::kNone);
      const Outcome out = RunPlan(pc.algorithm, wind, sc.start, sc.goal, pc.iterations, 1);
      // Admissible in the wind, risk and length EvaluateTrajectory's bit for bit.
      testing_planner::ExpectSoundStream(*wind, sc.start, sc.goal, out, pc.risk_ordered);
      if (!out.result.ok() || !out.result->best.has_value()) continue;
      const PlanImprovement& best = *out.result->best;
      auto pieces = PiecesFromWaypoints(best.waypoints, wind->params());
      ASSERT_TRUE(pieces.ok());
      auto eval = EvaluateTrajectory(*wind, *pieces);
      ASSERT_TRUE(eval.ok());
      EXPECT_TRUE(eval->admissible);
      EXPECT_EQ(best.risk, eval->risk);
      // Every admissibility sample's impact window, from the table alone, at
      // the air heading's bin with the wind's offset.
      int64_t samples = 0;
      testing_planner::ExpectImpactWindowsInside(*wind, best.waypoints, &samples);
      EXPECT_GT(samples, 0);
      // The manoeuvres are the wind's: the pieces use R_w, not R.
      EXPECT_GT(wind->params().GroundTurnRadius(), model_->params().turn_radius_m);
      // And the same trajectory in still air has another risk: the wind counts.
      bool calm_admissible = false;
      const double calm_risk = testing_planner::ReEvaluate(*model_, best.waypoints, &calm_admissible);
      EXPECT_NE(calm_risk, best.risk);
    }
  }
}

// The same seed and budget in the same wind give the same trajectory, bit
// for bit (the wind's model built twice, independently).
TEST_F(WindPlannersTest, RiskRrtStarInAWindIsDeterministic) {
  const Scenario& sc = Find("west-east");
  const Outcome a = RunPlan(PlannerAlgorithm::kRiskRrtStar, InWind(model_, 8.0, 270.0), sc.start,
                            sc.goal, 1000, 3);
  const Outcome b = RunPlan(PlannerAlgorithm::kRiskRrtStar, InWind(model_, 8.0, 270.0), sc.start,
                            sc.goal, 1000, 3);
  ASSERT_TRUE(a.result.ok() && b.result.ok());
  ASSERT_TRUE(a.result->best.has_value() && b.result->best.has_value());
  EXPECT_EQ(a.result->best->risk, b.result->best->risk);
  ASSERT_EQ(a.result->best->waypoints.size(), b.result->best->waypoints.size());
  for (size_t k = 0; k < a.result->best->waypoints.size(); ++k) {
    EXPECT_EQ(a.result->best->waypoints[k].x, b.result->best->waypoints[k].x);
    EXPECT_EQ(a.result->best->waypoints[k].y, b.result->best->waypoints[k].y);
  }
}

// A calm wind (W = 0, any direction) plans exactly what the default model
// plans: version 2, bit for bit.
TEST_F(WindPlannersTest, CalmWindPlansWhatStillAirPlans) {
  const Scenario& sc = Find("sw-ne");
  const Outcome still = RunPlan(PlannerAlgorithm::kRiskRrtStar, model_, sc.start, sc.goal, 800, 2);
  const Outcome calm =
      RunPlan(PlannerAlgorithm::kRiskRrtStar, InWind(model_, 0.0, 123.0), sc.start, sc.goal, 800, 2);
  ASSERT_TRUE(still.result.ok() && calm.result.ok());
  ASSERT_TRUE(still.result->best.has_value() && calm.result->best.has_value());
  EXPECT_EQ(still.result->best->risk, calm.result->best->risk);
  EXPECT_EQ(still.result->tree_size, calm.result->tree_size);
  EXPECT_EQ(still.result->configurations_evaluated, calm.result->configurations_evaluated);
}

// The guide route over uniform ground: its cost per step is time-weighted
// in a wind (lambda x M x length / gs of the step's direction), which scales
// every eastward step alike, so a uniform map's route stays straight in a
// cross-wind as in still air.
TEST(WindGuideTest, RouteOverUniformGroundStaysStraightInAWind) {
  const auto calm = testing_maps::SyntheticModel("uniform", 200, 120, 10.0, nullptr);
  ModelParams p = calm->params();
  p.wind_speed_mps = 9.0;
  p.wind_from_deg = 0.0;  // from the north: a cross-wind for an eastward route
  auto wind = RiskModel::Create(calm->map_ptr(), p, calm->table_ptr());
  ASSERT_TRUE(wind.ok()) << wind.status();
  DirectRiskEvaluator evaluator;
  const Pose start{400.0, 600.0, testing_maps::kFlightZM, 0.0};
  const Pose goal{1600.0, 600.0, testing_maps::kFlightZM, 0.0};
  for (const auto& model : {calm, *wind}) {
    auto route = CoarseRiskRoute(*model, start, goal, 50.0, 200.0, &evaluator);
    ASSERT_TRUE(route.ok()) << route.status();
    ASSERT_FALSE(route->empty());
    for (const Pose& q : *route) EXPECT_NEAR(q.y, 600.0, 30.0);
  }
}


// The air heading's bin that RiskModel reads from its table of track-heading
// intervals is the wind triangle's, bit for bit: every heading of a fine
// sweep, the bin boundaries' own track headings and their neighbours, for
// winds from several directions and speeds up to the bound.
TEST(WindAirBinTest, TheBinOfEveryTrackHeadingIsTheWindTrianglesBin) {
  const auto calm = testing_maps::SyntheticModel("uniform", 200, 200, 10.0, nullptr);
  const Pose centre{1000.0, 1000.0, testing_maps::kFlightZM, 0.0};
  for (const double speed : {0.5, 8.0, 9.0}) {
    for (const double from : {0.0, 33.0, 90.0, 271.5}) {
      ModelParams p = calm->params();
      p.wind_speed_mps = speed;
      p.wind_from_deg = from;
      auto model = RiskModel::Create(calm->map_ptr(), p, calm->table_ptr());
      ASSERT_TRUE(model.ok()) << model.status();
      const ImpactTable& t = (*model)->table();
      const WindTriangle& w = (*model)->wind();
      std::vector<double> thetas;
      for (int k = 0; k < 200000; ++k) thetas.push_back(kTwoPi * k / 200000.0);
      // Where the air heading crosses a bin boundary: bisect each interval
      // whose ends differ, down to adjacent doubles.
      const int n = 4096;
      for (int c = 0; c < n; ++c) {
        double a = kTwoPi * c / n;
        double b = kTwoPi * (c + 1) / n;
        if (t.HeadingBinOf(w.AirHeading(a)) == t.HeadingBinOf(w.AirHeading(b))) continue;
        for (int it = 0; it < 80 && std::nextafter(a, b) < b; ++it) {
          const double m = 0.5 * (a + b);
          (t.HeadingBinOf(w.AirHeading(m)) == t.HeadingBinOf(w.AirHeading(a)) ? a : b) = m;
        }
        for (double x = a, k = 0; k < 4; ++k, x = std::nextafter(x, 0.0)) thetas.push_back(x);
        for (double x = b, k = 0; k < 4; ++k, x = std::nextafter(x, 10.0)) thetas.push_back(x);
      }
      int64_t checked = 0;
      for (const double theta : thetas) {
        Pose q = centre;
        q.theta = theta;
        KernelSite site;
        ASSERT_TRUE((*model)->Locate(q, &site));
        ASSERT_EQ(site.heading_bin, t.HeadingBinOf(w.AirHeading(theta)))
            << "theta " << theta << " wind " << speed << " from " << from;
        ++checked;
      }
      EXPECT_GT(checked, 200000);
    }
  }
}

}  // namespace
}  // namespace riskplan
