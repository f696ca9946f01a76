// RISK_RRT_STAR under binding flight limits (issue 35): the tree's flight
// times and lengths to the goal, the Lagrangian's lambda, and the trajectory
// it returns within the limits (core/planners/risk_rrt_star_run.h, SetLimits).
#include <cmath>
#include <memory>
#include <optional>
#include <vector>

#include "core/flight/trajectory.h"
#include "core/planners/planner.h"
#include "core/planners/risk_rrt_star_run.h"
#include "core/risk/risk_evaluator.h"
#include "gtest/gtest.h"
#include "tests/core/planner_test_util.h"

namespace riskplan {
namespace {

using rrt_star::Node;

// The README's demo: about 440 s by the quickest routes the planner finds and
// 800 s by the safest (docs/benchmarks.md, "Limits on the demo").
const Pose kStart{1200, 1500, 250, 0.785};
const Pose kGoal{6800, 6500, 250, 0.785};

TrajectoryEvaluation Evaluate(const RiskModel& model, const std::vector<Pose>& waypoints) {
  auto pieces = PiecesFromWaypoints(waypoints, model.params());
  EXPECT_TRUE(pieces.ok());
  auto e = EvaluateTrajectory(model, *pieces);
  EXPECT_TRUE(e.ok());
  return *e;
}

struct RunOutcome {
  std::optional<PlanResult> result;
  std::vector<PlanImprovement> improvements;
  std::vector<Node> nodes;
  double lambda = 0.0;
};

RunOutcome RunWith(const RiskModel& model, const FlightLimits& limits, int64_t iterations,
                   uint64_t seed = 1) {
  RunOutcome out;
  auto params = rrt_star::Params::Parse({});
  EXPECT_TRUE(params.ok());
  DirectRiskEvaluator evaluator;
  CancellationToken cancel;
  rrt_star::RunCallbacks callbacks;
  callbacks.on_improvement = [&](size_t, const PlanImprovement& i) {
    out.improvements.push_back(i);
  };
  callbacks.on_result = [&](size_t, absl::StatusOr<PlanResult> r) {
    ASSERT_TRUE(r.ok()) << r.status();
    out.result = *std::move(r);
  };
  PlannerBudget budget;
  budget.max_time_s = 0.0;
  budget.max_iterations = iterations;
  rrt_star::Run run(model, kGoal, {{kStart, budget}}, seed, false, *params, &evaluator, cancel,
                    std::move(callbacks));
  run.SetLimits(limits);
  run.Execute();
  out.nodes = run.nodes();
  out.lambda = run.lambda();
  return out;
}

// Every `stride`-th node's flight time, length and risk to the goal equal
// EvaluateTrajectory's for its tree path (up to the rounding of sums made in
// another order).
void ExpectNodeSumsAreTheTreePaths(const RiskModel& model, const std::vector<Node>& nodes,
                                   size_t stride) {
  size_t checked = 0;
  for (size_t n = 1; n < nodes.size(); n += stride) {
    if (nodes[n].parent < 0) continue;  // a start never connected
    std::vector<Pose> path;
    for (int32_t k = static_cast<int32_t>(n); k >= 0; k = nodes[k].parent) {
      path.push_back(nodes[k].pose);
    }
    const TrajectoryEvaluation e = Evaluate(model, path);
    EXPECT_NEAR(nodes[n].to_goal_s, e.flight_time_s, 1e-9 * e.flight_time_s) << "node " << n;
    EXPECT_NEAR(nodes[n].to_goal_m, e.length_m, 1e-9 * e.length_m) << "node " << n;
    EXPECT_NEAR(nodes[n].cost, e.risk, 1e-9 * e.risk) << "node " << n;
    ++checked;
  }
  EXPECT_GT(checked, 10u);
}

class RiskRrtStarLimitsTest : public testing_planner::DemoCityPlannerTest {};

TEST_F(RiskRrtStarLimitsTest, EnduranceGivesAFittingTrajectoryAndExactNodeTimes) {
  FlightLimits limits;
  limits.max_flight_time_s = 600.0;
  const RunOutcome out = RunWith(*model_, limits, 1500);
  ASSERT_TRUE(out.result.has_value());
  ASSERT_TRUE(out.result->best.has_value());
  // The safest route (about 800 s) breaks the endurance: lambda was raised.
  EXPECT_GT(out.lambda, 0.0);
  const PlanImprovement& best = *out.result->best;
  const TrajectoryEvaluation e = Evaluate(*model_, best.waypoints);
  EXPECT_TRUE(e.admissible);
  EXPECT_EQ(e.risk, best.risk);
  EXPECT_EQ(e.length_m, best.length_m);
  EXPECT_LE(e.flight_time_s, limits.max_flight_time_s);
  // Once one fits, every report fits and lowers the risk.
  bool fitted = false;
  double last = 0.0;
  for (const PlanImprovement& i : out.improvements) {
    const double t = Evaluate(*model_, i.waypoints).flight_time_s;
    if (fitted) {
      EXPECT_LE(t, limits.max_flight_time_s);
      EXPECT_LT(i.risk, last);
    }
    if (t <= limits.max_flight_time_s) fitted = true;
    last = i.risk;
  }
  EXPECT_TRUE(fitted);
  ExpectNodeSumsAreTheTreePaths(*model_, out.nodes, std::max<size_t>(1, out.nodes.size() / 60));
}

TEST_F(RiskRrtStarLimitsTest, NodeTimesInAWindUseTheGroundSpeed) {
  ModelParams p = model_->params();
  p.wind_speed_mps = 8.0;
  p.wind_from_deg = 270.0;
  auto wind = RiskModel::Create(model_->map_ptr(), p, model_->table_ptr());
  ASSERT_TRUE(wind.ok()) << wind.status();
  FlightLimits limits;
  limits.max_flight_time_s = 600.0;
  const RunOutcome out = RunWith(**wind, limits, 600);
  ASSERT_TRUE(out.result.has_value());
  ASSERT_TRUE(out.result->best.has_value());
  const TrajectoryEvaluation e = Evaluate(**wind, out.result->best->waypoints);
  EXPECT_EQ(e.risk, out.result->best->risk);
  EXPECT_LE(e.flight_time_s, limits.max_flight_time_s);
  // Not the still-air time: the wind's ground speed.
  EXPECT_NE(e.flight_time_s, FlightTimeS(e.length_m, p.airspeed_mps));
  ExpectNodeSumsAreTheTreePaths(**wind, out.nodes, std::max<size_t>(1, out.nodes.size() / 40));
}

TEST_F(RiskRrtStarLimitsTest, ALengthLimitAloneIsPricedByLength) {
  FlightLimits limits;
  limits.max_length_m = 10000.0;  // the safest route is about 14.6 km
  const RunOutcome out = RunWith(*model_, limits, 1200);
  ASSERT_TRUE(out.result.has_value());
  ASSERT_TRUE(out.result->best.has_value());
  EXPECT_GT(out.lambda, 0.0);
  const TrajectoryEvaluation e = Evaluate(*model_, out.result->best->waypoints);
  EXPECT_EQ(e.risk, out.result->best->risk);
  EXPECT_EQ(e.length_m, out.result->best->length_m);
  EXPECT_LE(e.length_m, limits.max_length_m);
  ExpectNodeSumsAreTheTreePaths(*model_, out.nodes, std::max<size_t>(1, out.nodes.size() / 30));
}

TEST_F(RiskRrtStarLimitsTest, MinTimeUnderAnEnduranceReportsFallingTimes) {
  FlightLimits limits;
  limits.objective = PlanObjective::kMinTime;
  limits.max_flight_time_s = 700.0;
  const RunOutcome out = RunWith(*model_, limits, 1200);
  ASSERT_TRUE(out.result.has_value());
  ASSERT_TRUE(out.result->best.has_value());
  const TrajectoryEvaluation e = Evaluate(*model_, out.result->best->waypoints);
  EXPECT_LE(e.flight_time_s, limits.max_flight_time_s);
  // Once one fits, each report is quicker than the one before.
  std::optional<double> last;
  for (const PlanImprovement& i : out.improvements) {
    const double t = Evaluate(*model_, i.waypoints).flight_time_s;
    if (last.has_value()) {
      EXPECT_LT(t, *last);
    }
    if (t <= limits.max_flight_time_s) last = t;
  }
  ASSERT_TRUE(last.has_value());
  EXPECT_EQ(*last, e.flight_time_s);
}

TEST_F(RiskRrtStarLimitsTest, NoBindingLimitLeavesTheTreeWithoutTimes) {
  // MIN_RISK under a risk limit alone, and the front, are not bound by time:
  // the tree is the unlimited planner's.
  for (const bool pareto : {false, true}) {
    FlightLimits limits;
    limits.max_risk = 1e-5;
    limits.pareto = pareto;
    if (pareto) limits.max_flight_time_s = 600.0;
    const RunOutcome out = RunWith(*model_, limits, 200);
    const RunOutcome free = RunWith(*model_, FlightLimits{}, 200);
    EXPECT_EQ(out.lambda, 0.0);
    ASSERT_EQ(out.nodes.size(), free.nodes.size());
    for (size_t n = 0; n < out.nodes.size(); ++n) {
      EXPECT_EQ(out.nodes[n].to_goal_s, 0.0);
      EXPECT_EQ(out.nodes[n].parent, free.nodes[n].parent);
      EXPECT_EQ(out.nodes[n].cost, free.nodes[n].cost);
    }
  }
}

TEST_F(RiskRrtStarLimitsTest, MinTimeUnderARiskLimitIsQuickerAndWithinIt) {
  // The planner as the server runs it (through the limit filter).
  auto planner = MakePlanner(PlannerAlgorithm::kRiskRrtStar);
  ASSERT_TRUE(planner.ok());
  PlanningProblem problem{model_, kStart, kGoal};
  PlanOptions options;
  options.budget.max_time_s = 0.0;
  options.budget.max_iterations = 2000;
  CancellationToken cancel;
  auto free = (*planner)->Plan(problem, options, cancel, nullptr);
  ASSERT_TRUE(free.ok());
  ASSERT_TRUE(free->best.has_value());
  const TrajectoryEvaluation safest = Evaluate(*model_, free->best->waypoints);
  options.limits.objective = PlanObjective::kMinTime;
  options.limits.max_risk = 2.0 * free->best->risk;
  auto quick = (*planner)->Plan(problem, options, cancel, nullptr);
  ASSERT_TRUE(quick.ok());
  ASSERT_TRUE(quick->best.has_value());
  const TrajectoryEvaluation e = Evaluate(*model_, quick->best->waypoints);
  EXPECT_EQ(e.risk, quick->best->risk);
  EXPECT_EQ(e.flight_time_s, quick->best->flight_time_s);
  EXPECT_LE(e.risk, options.limits.max_risk);
  EXPECT_LT(e.flight_time_s, safest.flight_time_s);
}

TEST_F(RiskRrtStarLimitsTest, InfeasibleEnduranceStillNamesTheFastestTimeFound) {
  auto planner = MakePlanner(PlannerAlgorithm::kRiskRrtStar);
  ASSERT_TRUE(planner.ok());
  PlanningProblem problem{model_, kStart, kGoal};
  PlanOptions options;
  options.budget.max_time_s = 0.0;
  options.budget.max_iterations = 600;
  options.limits.max_flight_time_s = 200.0;  // the straight line alone takes 417 s
  CancellationToken cancel;
  auto result = (*planner)->Plan(problem, options, cancel, nullptr);
  ASSERT_TRUE(result.ok());
  EXPECT_FALSE(result->best.has_value());
  EXPECT_EQ(result->reason, StopReason::kNoSolution);
  ASSERT_TRUE(result->limits.fastest_flight_time_s.has_value());
  EXPECT_GT(*result->limits.fastest_flight_time_s, 400.0);
  EXPECT_NE(result->limits.note.find("the fastest trajectory found flies"), std::string::npos)
      << result->limits.note;
}

}  // namespace
}  // namespace riskplan
