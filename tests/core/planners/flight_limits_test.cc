// Limits on every plan (issue 35): endurance, length, target level of safety
// per flight and per flight hour, MIN_TIME, the risk-time front. Every
// planner honours them: nothing streamed or returned breaks a limit, every
// risk and flight time is EvaluateTrajectory's bit for bit, and a plan whose
// trajectories all break a limit ends NO_SOLUTION with a note naming it.
#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "core/flight/trajectory.h"
#include "core/planners/flight_limits.h"
#include "core/planners/limit_filter.h"
#include "core/planners/planner.h"
#include "gtest/gtest.h"
#include "tests/core/planner_test_util.h"
#include "tests/core/seed_planner_test_util.h"

namespace riskplan {
namespace {

using testing_planner::Outcome;
using testing_planner::RunPlan;
using testing_planner::Scenario;

struct PlannerCase {
  PlannerAlgorithm algorithm;
  int64_t iterations;
};
constexpr PlannerCase kPlanners[] = {
    {PlannerAlgorithm::kRiskRrtStar, 1500},
    {PlannerAlgorithm::kRrt, 20000},
    {PlannerAlgorithm::kGenetic, 40},
    {PlannerAlgorithm::kHarmonic, 20000},
};

// EvaluateTrajectory of `waypoints`.
TrajectoryEvaluation Evaluate(const RiskModel& model, const std::vector<Pose>& waypoints) {
  auto pieces = PiecesFromWaypoints(waypoints, model.params());
  EXPECT_TRUE(pieces.ok());
  auto eval = EvaluateTrajectory(model, *pieces);
  EXPECT_TRUE(eval.ok());
  return *eval;
}

// Everything streamed and returned meets `limits`, with EvaluateTrajectory's
// exact risk, length and flight time.
void ExpectWithin(const RiskModel& model, const FlightLimits& limits, const Outcome& out) {
  ASSERT_TRUE(out.result.ok()) << out.result.status();
  std::vector<const PlanImprovement*> all;
  for (const PlanImprovement& i : out.improvements) all.push_back(&i);
  if (out.result->best.has_value()) all.push_back(&*out.result->best);
  for (const PlanImprovement* i : all) {
    const TrajectoryEvaluation e = Evaluate(model, i->waypoints);
    EXPECT_TRUE(e.admissible);
    EXPECT_EQ(i->risk, e.risk);
    EXPECT_EQ(i->length_m, e.length_m);
    EXPECT_EQ(i->flight_time_s, e.flight_time_s);
    if (limits.max_flight_time_s > 0) {
      EXPECT_LE(e.flight_time_s, limits.max_flight_time_s);
    }
    if (limits.max_length_m > 0) {
      EXPECT_LE(e.length_m, limits.max_length_m);
    }
    if (limits.max_risk > 0) {
      EXPECT_LE(e.risk, limits.max_risk);
    }
    if (limits.max_risk_per_flight_hour > 0) {
      EXPECT_LE(RiskPerFlightHour(e.risk, e.flight_time_s), limits.max_risk_per_flight_hour);
    }
    EXPECT_TRUE(NonDominated(i->front));
  }
  // Every point of the last streamed front and of the final one is exact
  // and within the limits (the earlier fronts hold the same kind of points:
  // each entered the front once).
  std::vector<const FrontPoint*> points;
  if (!out.improvements.empty()) {
    for (const FrontPoint& p : out.improvements.back().front) points.push_back(&p);
  }
  for (const FrontPoint& p : out.result->front) points.push_back(&p);
  EXPECT_TRUE(NonDominated(out.result->front));
  {
    for (const FrontPoint* q : points) {
      const FrontPoint& p = *q;
      const TrajectoryEvaluation f = Evaluate(model, p.waypoints);
      EXPECT_EQ(p.risk, f.risk);
      EXPECT_EQ(p.flight_time_s, f.flight_time_s);
      if (limits.max_flight_time_s > 0) {
        EXPECT_LE(f.flight_time_s, limits.max_flight_time_s);
      }
    }
  }
}

class FlightLimitsTest : public testing_planner::DemoCityPlannerTest {
 protected:
  const Scenario& Find(const std::string& name) {
    for (const Scenario& s : scenarios_) {
      if (name == s.name) return s;
    }
    ADD_FAILURE() << "no scenario " << name;
    return scenarios_.front();
  }
  Outcome Plan(const PlannerCase& pc, const Scenario& sc, const FlightLimits& limits,
               uint64_t seed = 1) {
    PlanOptions options;
    options.limits = limits;
    return RunPlan(pc.algorithm, model_, sc.start, sc.goal, pc.iterations, seed, {}, options);
  }
};

TEST(FlightLimits, CheckNamesTheField) {
  FlightLimits limits;
  EXPECT_TRUE(CheckFlightLimits(limits).ok());
  EXPECT_FALSE(limits.Active());
  limits.max_flight_time_s = -1;
  absl::Status s = CheckFlightLimits(limits);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("limits.max_flight_time_s"), std::string::npos) << s;
  limits = {};
  limits.max_risk_per_flight_hour = std::nan("");
  s = CheckFlightLimits(limits);
  EXPECT_NE(s.message().find("limits.max_risk_per_flight_hour"), std::string::npos) << s;
  limits = {};
  limits.objective = static_cast<PlanObjective>(7);
  s = CheckFlightLimits(limits);
  EXPECT_NE(s.message().find("limits.objective"), std::string::npos) << s;
  limits = {};
  limits.pareto = true;
  EXPECT_TRUE(limits.Active());
}

TEST(FlightLimits, FrontKeepsTheNonDominated) {
  std::vector<FrontPoint> front;
  auto point = [](double risk, double t) {
    FrontPoint p;
    p.risk = risk;
    p.flight_time_s = t;
    return p;
  };
  EXPECT_TRUE(AddToFront(&front, point(5, 100)));
  EXPECT_TRUE(AddToFront(&front, point(3, 200)));
  EXPECT_TRUE(AddToFront(&front, point(8, 50)));
  EXPECT_FALSE(AddToFront(&front, point(6, 150)));  // dominated by (5, 100)
  EXPECT_FALSE(AddToFront(&front, point(5, 100)));  // equal
  EXPECT_TRUE(AddToFront(&front, point(4, 90)));    // dominates (5, 100)
  ASSERT_EQ(front.size(), 3u);
  EXPECT_EQ(front[0].flight_time_s, 50);
  EXPECT_EQ(front[1].flight_time_s, 90);
  EXPECT_EQ(front[2].flight_time_s, 200);
  EXPECT_TRUE(NonDominated(front));
  front.push_back(point(9, 300));
  EXPECT_FALSE(NonDominated(front));
}

// Each planner with an endurance a little under its own unconstrained
// trajectory's flight time: nothing it streams or returns flies longer; it
// returns a trajectory or says why not.
TEST_F(FlightLimitsTest, EveryPlannerHonoursTheEndurance) {
  const Scenario& sc = Find("sw-ne");
  for (const PlannerCase& pc : kPlanners) {
    SCOPED_TRACE(std::string(PlannerAlgorithmName(pc.algorithm)));
    const Outcome free = Plan(pc, sc, {});
    ASSERT_TRUE(free.result.ok());
    ASSERT_TRUE(free.result->best.has_value());
    const double t = Evaluate(*model_, free.result->best->waypoints).flight_time_s;
    FlightLimits limits;
    limits.max_flight_time_s = 0.99 * t;
    limits.pareto = true;
    const Outcome out = Plan(pc, sc, limits);
    ExpectWithin(*model_, limits, out);
    if (!out.result->best.has_value()) {
      EXPECT_EQ(out.result->reason, StopReason::kNoSolution);
      EXPECT_NE(out.result->limits.note.find("no trajectory within the endurance"),
                std::string::npos)
          << out.result->limits.note;
    } else {
      EXPECT_FALSE(out.result->front.empty());
    }
    EXPECT_GE(out.result->limits.candidates, 1);
  }
}

TEST_F(FlightLimitsTest, EveryPlannerHonoursLengthAndRiskLimits) {
  const Scenario& sc = Find("sw-ne");
  for (const PlannerCase& pc : kPlanners) {
    SCOPED_TRACE(std::string(PlannerAlgorithmName(pc.algorithm)));
    const Outcome free = Plan(pc, sc, {});
    ASSERT_TRUE(free.result.ok() && free.result->best.has_value());
    const TrajectoryEvaluation e = Evaluate(*model_, free.result->best->waypoints);
    FlightLimits limits;
    limits.max_length_m = 1.5 * e.length_m;
    limits.max_risk = 1.5 * e.risk;
    limits.max_risk_per_flight_hour = 1.5 * RiskPerFlightHour(e.risk, e.flight_time_s);
    const Outcome out = Plan(pc, sc, limits);
    ExpectWithin(*model_, limits, out);
    // The unconstrained best meets these limits, so a trajectory is found.
    EXPECT_TRUE(out.result->best.has_value());
  }
}

// An endurance no route can meet: NO_SOLUTION, no trajectory streamed, and
// the note gives the fastest flight time found.
TEST_F(FlightLimitsTest, InfeasibleEnduranceSaysSoWithTheFastestTime) {
  const Scenario& sc = Find("sw-ne");
  for (const PlannerCase& pc : kPlanners) {
    SCOPED_TRACE(std::string(PlannerAlgorithmName(pc.algorithm)));
    FlightLimits limits;
    limits.max_flight_time_s = 10.0;
    const Outcome out = Plan(pc, sc, limits);
    ASSERT_TRUE(out.result.ok());
    EXPECT_TRUE(out.improvements.empty());
    EXPECT_FALSE(out.result->best.has_value());
    EXPECT_EQ(out.result->reason, StopReason::kNoSolution);
    ASSERT_TRUE(out.result->limits.fastest_flight_time_s.has_value());
    EXPECT_GT(*out.result->limits.fastest_flight_time_s, 10.0);
    EXPECT_NE(out.result->limits.note.find(
                  "no trajectory within the endurance (max_flight_time_s = 10 s): the fastest "
                  "trajectory found flies"),
              std::string::npos)
        << out.result->limits.note;
  }
  // A risk target no route meets names that limit.
  FlightLimits limits;
  limits.max_risk = 1e-30;
  const Outcome out = Plan(kPlanners[0], sc, limits);
  ASSERT_TRUE(out.result.ok());
  EXPECT_FALSE(out.result->best.has_value());
  EXPECT_NE(out.result->limits.note.find("max_risk = 1e-30 per flight"), std::string::npos)
      << out.result->limits.note;
}

// MIN_TIME with a per-flight risk limit of twice the MIN_RISK plan's risk:
// the trajectory meets it, is no slower than the MIN_RISK one, and the
// stream goes by decreasing flight time.
TEST_F(FlightLimitsTest, MinTimeMeetsTheRiskTargetAndIsQuicker) {
  const Scenario& sc = Find("sw-ne");
  for (const PlannerCase& pc : kPlanners) {
    SCOPED_TRACE(std::string(PlannerAlgorithmName(pc.algorithm)));
    const Outcome free = Plan(pc, sc, {});
    ASSERT_TRUE(free.result.ok() && free.result->best.has_value());
    const TrajectoryEvaluation e = Evaluate(*model_, free.result->best->waypoints);
    FlightLimits limits;
    limits.max_risk = 2.0 * e.risk;
    limits.objective = PlanObjective::kMinTime;
    const Outcome out = Plan(pc, sc, limits);
    ExpectWithin(*model_, limits, out);
    ASSERT_TRUE(out.result->best.has_value());
    EXPECT_LE(out.result->best->flight_time_s, e.flight_time_s);
    for (size_t k = 1; k < out.improvements.size(); ++k) {
      if (out.improvements[k].replanned) continue;
      EXPECT_LT(out.improvements[k].flight_time_s, out.improvements[k - 1].flight_time_s);
    }
  }
}

// The streamed front: non-dominated at every message, every point exact and
// within the limits; the final front holds the final best of MIN_RISK.
TEST_F(FlightLimitsTest, StreamedFrontIsNonDominated) {
  const Scenario& sc = Find("sw-ne");
  FlightLimits limits;
  limits.pareto = true;
  const PlannerCase pc{PlannerAlgorithm::kRiskRrtStar, 3000};
  const Outcome out = Plan(pc, sc, limits, 5);
  ExpectWithin(*model_, limits, out);
  ASSERT_TRUE(out.result->best.has_value());
  ASSERT_FALSE(out.result->front.empty());
  EXPECT_TRUE(NonDominated(out.result->front));
  // The lowest-risk point of the front is the best.
  EXPECT_EQ(out.result->front.back().risk, out.result->best->risk);
  for (size_t k = 1; k < out.result->front.size(); ++k) {
    EXPECT_LT(out.result->front[k - 1].flight_time_s, out.result->front[k].flight_time_s);
    EXPECT_GT(out.result->front[k - 1].risk, out.result->front[k].risk);
  }
}

// A limit every trajectory meets changes nothing but the flight times
// reported: same trajectories, bit for bit.
TEST_F(FlightLimitsTest, LooseLimitsChangeNothing) {
  const Scenario& sc = Find("sw-ne");
  FlightLimits loose;
  loose.max_risk = 1.0;
  const Outcome a = Plan(kPlanners[0], sc, {});
  const Outcome b = Plan(kPlanners[0], sc, loose);
  ASSERT_TRUE(a.result.ok() && b.result.ok());
  ASSERT_TRUE(a.result->best.has_value() && b.result->best.has_value());
  EXPECT_EQ(a.result->best->risk, b.result->best->risk);
  EXPECT_EQ(a.improvements.size(), b.improvements.size());
  EXPECT_EQ(a.result->best->flight_time_s, 0.0);
  EXPECT_GT(b.result->best->flight_time_s, 0.0);
}

// In a wind the flight time is the ground speed's: every time streamed is
// EvaluateTrajectory's in that wind, and the endurance bounds it.
TEST_F(FlightLimitsTest, EnduranceInAWindUsesTheGroundSpeed) {
  ModelParams p = model_->params();
  p.wind_speed_mps = 8.0;
  p.wind_from_deg = 270.0;
  auto wind = RiskModel::Create(model_->map_ptr(), p, model_->table_ptr());
  ASSERT_TRUE(wind.ok()) << wind.status();
  const Scenario& sc = Find("sw-ne");
  const Outcome free =
      RunPlan(PlannerAlgorithm::kRiskRrtStar, *wind, sc.start, sc.goal, 800, 1, {}, {});
  ASSERT_TRUE(free.result.ok() && free.result->best.has_value());
  const TrajectoryEvaluation e = Evaluate(**wind, free.result->best->waypoints);
  // With the wind behind it the route is quicker than length / airspeed.
  EXPECT_NE(e.flight_time_s, FlightTimeS(e.length_m, p.airspeed_mps));
  PlanOptions options;
  options.limits.max_flight_time_s = e.flight_time_s;
  options.limits.pareto = true;
  const Outcome out =
      RunPlan(PlannerAlgorithm::kRiskRrtStar, *wind, sc.start, sc.goal, 800, 1, {}, options);
  ExpectWithin(**wind, options.limits, out);
  EXPECT_FALSE(out.improvements.empty());
}

// RISK_RRT_STAR under an endurance runs an unguided pass then a guided one,
// each with half the iterations; the counts add up and the second pass's
// improvements count from the first's start.
TEST_F(FlightLimitsTest, RiskRrtStarTradesTimeInTwoPasses) {
  PlanOptions options;
  options.budget.max_iterations = 1001;
  options.limits.max_flight_time_s = 1000;
  // MIN_RISK: a guided probe of a quarter, then (until the probe chooses)
  // an unguided pass.
  std::vector<PlanOptions> passes = LimitPasses(PlannerAlgorithm::kRiskRrtStar, options);
  ASSERT_EQ(passes.size(), 2u);
  EXPECT_EQ(passes[0].params.count("guide_cell_m"), 0u);
  EXPECT_EQ(passes[1].params.at("guide_cell_m"), 0.0);
  EXPECT_EQ(passes[0].budget.max_iterations, 250);
  EXPECT_EQ(passes[1].budget.max_iterations, 751);
  // The front: half unguided, half guided.
  options.limits.pareto = true;
  passes = LimitPasses(PlannerAlgorithm::kRiskRrtStar, options);
  ASSERT_EQ(passes.size(), 2u);
  EXPECT_EQ(passes[0].params.at("guide_cell_m"), 0.0);
  EXPECT_EQ(passes[1].params.count("guide_cell_m"), 0u);
  EXPECT_EQ(passes[0].budget.max_iterations, 500);
  EXPECT_EQ(passes[1].budget.max_iterations, 501);
  options.limits.pareto = false;
  options.params["guide_cell_m"] = 50;  // the caller's choice stands
  EXPECT_EQ(LimitPasses(PlannerAlgorithm::kRiskRrtStar, options).size(), 1u);
  options.params.clear();
  EXPECT_EQ(LimitPasses(PlannerAlgorithm::kRrt, options).size(), 1u);
  options.limits = {};
  options.limits.max_risk = 1e-6;  // no time traded
  EXPECT_EQ(LimitPasses(PlannerAlgorithm::kRiskRrtStar, options).size(), 1u);

  const Scenario& sc = Find("sw-ne");
  FlightLimits limits;
  limits.max_flight_time_s = 1e9;
  const Outcome out = Plan({PlannerAlgorithm::kRiskRrtStar, 1200}, sc, limits);
  ExpectWithin(*model_, limits, out);
  ASSERT_TRUE(out.result->best.has_value());
  EXPECT_EQ(out.result->iterations, 1200);
  for (size_t k = 1; k < out.improvements.size(); ++k) {
    EXPECT_GE(out.improvements[k].iterations, out.improvements[k - 1].iterations);
    EXPECT_LT(out.improvements[k].risk, out.improvements[k - 1].risk);
  }
}

}  // namespace
}  // namespace riskplan
