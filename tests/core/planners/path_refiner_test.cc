#include "core/planners/path_refiner.h"

#include <vector>

#include "core/flight/trajectory.h"
#include "core/planners/risk_guide.h"
#include "gtest/gtest.h"
#include "tests/core/planner_test_util.h"

namespace riskplan {
namespace {

using testing_planner::DemoCityModel;
using testing_planner::DemoCityScenarios;
using testing_planner::Scenario;

absl::StatusOr<TrajectoryEvaluation> Evaluate(const RiskModel& model,
                                              const std::vector<Pose>& waypoints) {
  auto pieces = PiecesFromWaypoints(waypoints, model.params());
  if (!pieces.ok()) return pieces.status();
  return EvaluateTrajectory(model, *pieces);
}

std::vector<Pose> Apply(const std::vector<Pose>& waypoints, const PathRefiner::Edit& edit) {
  std::vector<Pose> out(waypoints.begin(), waypoints.begin() + edit.first + 1);
  if (edit.has_waypoint) out.push_back(edit.waypoint);
  out.insert(out.end(), waypoints.begin() + edit.last, waypoints.end());
  return out;
}

// Every accepted edit keeps the trajectory admissible, lowers the risk of the
// pieces it replaces, and reports exactly EvaluateTrajectory's piece risks.
TEST(PathRefinerTest, AcceptedEditsAreAdmissibleLowerAndExact) {
  auto model = DemoCityModel();
  int accepted_total = 0;
  int trajectories = 0;
  for (const Scenario& sc : DemoCityScenarios(*model)) {
    if (!sc.crosses_centre) continue;
    DirectRiskEvaluator evaluator;
    auto route = CoarseRiskRoute(*model, sc.start, sc.goal, 160.0, 400.0, &evaluator);
    ASSERT_TRUE(route.ok()) << route.status();
    std::vector<Pose> waypoints = {sc.start};
    waypoints.insert(waypoints.end(), route->begin(), route->end());
    waypoints.push_back(sc.goal);
    auto eval = Evaluate(*model, waypoints);
    ASSERT_TRUE(eval.ok());
    if (!eval->admissible) continue;  // the route is a heuristic; not every one is flyable
    if (++trajectories > 3) break;
    SCOPED_TRACE(sc.name);
    std::vector<double> risks;
    for (const PieceEvaluation& p : eval->pieces) risks.push_back(p.risk);
    double risk = eval->risk;
    PathRefiner refiner(*model, &evaluator, 200.0, 16);
    Rng rng(7);
    int accepted = 0;
    for (int attempt = 0; attempt < 150; ++attempt) {
      PathRefiner::Edit edit;
      absl::StatusOr<bool> improved = refiner.TryEdit(waypoints, risks, rng, &edit);
      ASSERT_TRUE(improved.ok());
      if (!*improved) continue;
      ++accepted;
      ASSERT_LT(edit.first, edit.last);
      ASSERT_LE(edit.last, waypoints.size() - 1);
      double replaced = 0.0;
      for (size_t i = edit.first; i < edit.last; ++i) replaced += risks[i];
      EXPECT_LT(edit.risk_in + edit.risk_out, replaced);
      std::vector<Pose> next = Apply(waypoints, edit);
      auto next_eval = Evaluate(*model, next);
      ASSERT_TRUE(next_eval.ok());
      ASSERT_TRUE(next_eval->admissible) << next_eval->first_violation->ToString();
      EXPECT_EQ(next_eval->pieces[edit.first].risk, edit.risk_in);
      if (edit.has_waypoint) {
        EXPECT_EQ(next_eval->pieces[edit.first + 1].risk, edit.risk_out);
      }
      EXPECT_LT(next_eval->risk, risk);
      waypoints = std::move(next);
      risks.clear();
      for (const PieceEvaluation& p : next_eval->pieces) risks.push_back(p.risk);
      risk = next_eval->risk;
    }
    EXPECT_GT(accepted, 0);
    accepted_total += accepted;
  }
  EXPECT_GE(trajectories, 2);
  EXPECT_GT(accepted_total, 10);
}

TEST(PathRefinerTest, SameRandomStreamGivesTheSameEdits) {
  auto model = DemoCityModel();
  const Scenario sc = DemoCityScenarios(*model)[0];
  const std::vector<Pose> waypoints = {sc.start, sc.goal};
  auto eval = Evaluate(*model, waypoints);
  ASSERT_TRUE(eval.ok());
  const std::vector<double> risks = {eval->pieces[0].risk};
  DirectRiskEvaluator evaluator;
  PathRefiner a(*model, &evaluator, 200.0, 16);
  PathRefiner b(*model, &evaluator, 200.0, 16);
  Rng ra(3);
  Rng rb(3);
  for (int attempt = 0; attempt < 40; ++attempt) {
    PathRefiner::Edit ea;
    PathRefiner::Edit eb;
    auto ia = a.TryEdit(waypoints, risks, ra, &ea);
    auto ib = b.TryEdit(waypoints, risks, rb, &eb);
    ASSERT_TRUE(ia.ok() && ib.ok());
    ASSERT_EQ(*ia, *ib);
    if (!*ia) continue;
    EXPECT_EQ(ea.waypoint.x, eb.waypoint.x);
    EXPECT_EQ(ea.waypoint.theta, eb.waypoint.theta);
    EXPECT_EQ(ea.risk_in, eb.risk_in);
    EXPECT_EQ(ea.risk_out, eb.risk_out);
  }
}

TEST(PathRefinerTest, NothingToGainOnARiskFreeTrajectory) {
  auto model = DemoCityModel();
  const Scenario sc = DemoCityScenarios(*model)[0];
  DirectRiskEvaluator evaluator;
  PathRefiner refiner(*model, &evaluator, 200.0, 16);
  Rng rng(1);
  PathRefiner::Edit edit;
  const std::vector<Pose> waypoints = {sc.start, sc.goal};
  const std::vector<double> zero = {0.0};
  for (int attempt = 0; attempt < 10; ++attempt) {
    auto improved = refiner.TryEdit(waypoints, zero, rng, &edit);
    ASSERT_TRUE(improved.ok());
    EXPECT_FALSE(*improved);
  }
  EXPECT_EQ(evaluator.evaluated(), 0u);
}

}  // namespace
}  // namespace riskplan
