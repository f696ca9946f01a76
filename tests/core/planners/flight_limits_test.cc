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
    if (limits.max_flight_time_s > 0) EXPECT_LE(e.flight_time_s, limits.max_flight_time_s);
    if (limits.max_length_m > 0) EXPECT_LE(e.length_m, limits.max_length_m);
    if (limits.max_risk > 0) EXPECT_LE(e.risk, limits.max_risk);
    if (limits.max_risk_per_flight_hour > 0) {
      EXPECT_LE(RiskPerFlightHour(e.risk, e.flight_time_s), limits.max_risk_per_flight_hour);
    }
    for (const FrontPoint& p : i->front) {
      const TrajectoryEvaluation f = Evaluate(model, p.waypoints);
      EXPECT_EQ(p.risk, f.risk);
      EXPECT_EQ(p.flight_time_s, f.flight_time_s);
      if (limits.max_flight_time_s > 0) EXPECT_LE(f.flight_time_s, limits.max_flight_time_s);
    }
    EXPECT_TRUE(NonDominated(i->front));
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

// With no limits the planners are unchanged: same trajectory, bit for bit.
TEST_F(FlightLimitsTest, InactiveLimitsChangeNothing) {
  const Scenario& sc = Find("sw-ne");
  FlightLimits loose;
  loose.max_flight_time_s = 1e9;
  const Outcome a = Plan(kPlanners[0], sc, {});
  const Outcome b = Plan(kPlanners[0], sc, loose);
  ASSERT_TRUE(a.result.ok() && b.result.ok());
  ASSERT_TRUE(a.result->best.has_value() && b.result->best.has_value());
  EXPECT_EQ(a.result->best->risk, b.result->best->risk);
  EXPECT_EQ(a.improvements.size(), b.improvements.size());
  EXPECT_EQ(a.result->best->flight_time_s, 0.0);
  EXPECT_GT(b.result->best->flight_time_s, 0.0);
}

}  // namespace
}  // namespace riskplan
