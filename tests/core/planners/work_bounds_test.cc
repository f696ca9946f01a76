// The work a plan may do, bounded before it starts (the samples of any edge a
// planner flies) and inside it (every planner's budget and token end a run
// in the middle of a step, not only between steps).
#include <cmath>
#include <map>
#include <string>

#include "absl/strings/str_format.h"
#include "core/base/random.h"
#include "core/flight/dubins.h"
#include "core/flight/piece_risk.h"
#include "core/planners/planner.h"
#include "core/planners/planner_support.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/core/planner_test_util.h"

namespace riskplan {
namespace {

using ::testing::HasSubstr;
using testing_planner::DemoCityModel;
using testing_planner::DemoCityScenarios;
using testing_planner::Scenario;

constexpr PlannerAlgorithm kAlgorithms[] = {PlannerAlgorithm::kRiskRrtStar, PlannerAlgorithm::kRrt,
                                            PlannerAlgorithm::kGenetic,
                                            PlannerAlgorithm::kHarmonic};

// Random poses anywhere a planner may fly: on the map, between the lowest
// terrain and the highest ceiling.
Pose RandomFlightPose(const RiskMap& map, const ModelParams& p, Rng& rng) {
  const double low = map.terrain_min_m();
  const double high = map.terrain_max_m() + p.max_agl_m;
  return Pose{map.x0() + rng.Uniform() * map.width_m(), map.y0() + rng.Uniform() * map.height_m(),
              low + rng.Uniform() * (high - low), rng.Uniform() * kTwoPi};
}

// The projection is an upper bound of every manoeuvre between such poses,
// whatever the turning radius and climb limit (here at their extremes).
TEST(EdgeSampleBoundTest, BoundsEveryManoeuvreBetweenFlightPoses) {
  const auto model = DemoCityModel();
  const RiskMap& map = model->map();
  Rng rng(11);
  for (const auto& [radius, climb] :
       {std::pair{50.0, 0.15}, {1.0, 0.01}, {10000.0, 0.01}, {1.0, 1.4}, {10000.0, 1.4}}) {
    ModelParams p;
    p.turn_radius_m = radius;
    p.max_climb_rad = climb;
    const Pose start = RandomFlightPose(map, p, rng);
    const Pose goal = RandomFlightPose(map, p, rng);
    const EdgeSampleBound b =
        ProjectEdgeSamples(PlannerAlgorithm::kRiskRrtStar, map, p, start, goal, {});
    double longest = 0.0;
    for (int k = 0; k < 2000; ++k) {
      const Pose a = RandomFlightPose(map, p, rng);
      const Pose c = RandomFlightPose(map, p, rng);
      longest = std::max(longest, DubinsAirplanePath(a, c, radius, climb).Length());
    }
    // The two extreme corners at the extreme altitudes, too.
    const Pose sw{map.x0(), map.y0(), map.terrain_min_m(), 0.0};
    const Pose ne{map.x0() + map.width_m(), map.y0() + map.height_m(),
                  map.terrain_max_m() + p.max_agl_m, kPi};
    longest = std::max(longest, DubinsAirplanePath(sw, ne, radius, climb).Length());
    EXPECT_LE(longest, b.length_m) << radius << " " << climb;
    EXPECT_EQ(b.samples, PartCount(b.length_m, p.sample_step_m) + 2);
  }
}

// GENETIC samples its fitness at risk_step_m, and a fixed altitude widens the
// climbs: both enter the bound.
TEST(EdgeSampleBoundTest, FinerStepsAndNamedAltitudesEnterTheBound) {
  const auto model = DemoCityModel();
  const RiskMap& map = model->map();
  ModelParams p;
  p.sample_step_m = 50.0;
  const Pose pose{1000.0, 1000.0, 250.0, 0.0};
  const EdgeSampleBound plain =
      ProjectEdgeSamples(PlannerAlgorithm::kGenetic, map, p, pose, pose, {});
  EXPECT_EQ(plain.step_m, 25.0);  // risk_step_m's default
  const EdgeSampleBound fine =
      ProjectEdgeSamples(PlannerAlgorithm::kGenetic, map, p, pose, pose, {{"risk_step_m", 1.0}});
  EXPECT_EQ(fine.step_m, 1.0);
  const EdgeSampleBound high = ProjectEdgeSamples(PlannerAlgorithm::kGenetic, map, p, pose, pose,
                                                  {{"fixed_altitude_m", 20000.0}});
  EXPECT_EQ(high.climb_m, 20000.0 - map.terrain_min_m());
  const EdgeSampleBound rrt = ProjectEdgeSamples(PlannerAlgorithm::kRrt, map, p, pose, pose,
                                                 {{"flight_altitude_m", 20000.0}});
  EXPECT_EQ(rrt.climb_m, high.climb_m);
  EXPECT_EQ(rrt.step_m, 50.0);
}

// PlanOptions::max_edge_samples (the server's --max_edge_samples) at, just
// under and just over the projection.
TEST(EdgeSampleBoundTest, CheckedAtUnderAndOver) {
  const auto model = DemoCityModel();
  const Scenario sc = DemoCityScenarios(*model).front();
  const PlanningProblem problem{model, sc.start, sc.goal};
  const EdgeSampleBound b = ProjectEdgeSamples(PlannerAlgorithm::kRiskRrtStar, model->map(),
                                               model->params(), sc.start, sc.goal, {});
  PlanOptions options;
  options.max_edge_samples = b.samples;
  EXPECT_TRUE(CheckEdgeSamples(PlannerAlgorithm::kRiskRrtStar, problem, options).ok());
  options.max_edge_samples = b.samples + 1;
  EXPECT_TRUE(CheckEdgeSamples(PlannerAlgorithm::kRiskRrtStar, problem, options).ok());
  options.max_edge_samples = b.samples - 1;
  const absl::Status over = CheckEdgeSamples(PlannerAlgorithm::kRiskRrtStar, problem, options);
  EXPECT_EQ(over.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(over.message(),
            absl::StrFormat("an edge of a RISK_RRT_STAR plan on map 'demo-city' may need %d "
                            "samples: up to %.1f m long (the map's diagonal %.1f m, turn_radius_m "
                            "50, climbs of up to %.1f m at max_climb_rad 0.15) sampled every 5 m "
                            "(sample_step_m); the limit is %d samples per edge",
                            b.samples, b.length_m, b.map_diagonal_m, b.climb_m, b.samples - 1));
}

// Every planner checks the bound before it plans.
TEST(EdgeSampleBoundTest, EveryPlannerRefusesAPlanBeyondIt) {
  const auto model = DemoCityModel();
  const Scenario sc = DemoCityScenarios(*model).front();
  for (PlannerAlgorithm algorithm : kAlgorithms) {
    SCOPED_TRACE(PlannerAlgorithmName(algorithm));
    auto planner = MakePlanner(algorithm);
    ASSERT_TRUE(planner.ok());
    PlanOptions options;
    options.budget.max_iterations = 10;
    options.budget.max_time_s = 0.0;
    options.max_edge_samples = 100;
    CancellationToken cancel;
    auto result = (*planner)->Plan({model, sc.start, sc.goal}, options, cancel, nullptr);
    ASSERT_FALSE(result.ok());
    EXPECT_EQ(result.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_THAT(std::string(result.status().message()), HasSubstr("samples per edge"));
  }
}

// Plans the first demo-city scenario with `algorithm`, without a callback.
absl::StatusOr<PlanResult> PlanFirstScenario(PlannerAlgorithm algorithm, const PlanOptions& options,
                                             const CancellationToken& cancel) {
  const auto model = DemoCityModel();
  const Scenario sc = DemoCityScenarios(*model).front();
  auto planner = MakePlanner(algorithm);
  EXPECT_TRUE(planner.ok());
  if (!planner.ok()) return planner.status();
  return (*planner)->Plan({model, sc.start, sc.goal}, options, cancel, nullptr);
}

// A time budget that has already ended when the run starts stops it at the
// first poll inside its first step: RISK_RRT_STAR adds no node (its guide's
// first risk batch is not evaluated), GENETIC evaluates no chromosome. Without
// the polls inside a step they would finish it (the guide route, the first
// generation) before looking at the clock. Deterministic: the deadline has
// passed whatever the machine's speed.
TEST(RunStopTest, AnEndedBudgetStopsTheRunInsideItsFirstStep) {
  for (PlannerAlgorithm algorithm : {PlannerAlgorithm::kRiskRrtStar, PlannerAlgorithm::kGenetic}) {
    SCOPED_TRACE(PlannerAlgorithmName(algorithm));
    PlanOptions options;
    options.budget.max_time_s = 1e-9;
    CancellationToken cancel;
    auto result = PlanFirstScenario(algorithm, options, cancel);
    ASSERT_TRUE(result.ok()) << result.status();
    EXPECT_EQ(result->reason, StopReason::kNoSolution);
    EXPECT_FALSE(result->best.has_value());
    EXPECT_EQ(result->iterations, 0);
    // Start and goal (RISK_RRT_STAR); chromosomes evaluated (GENETIC).
    EXPECT_EQ(result->tree_size, algorithm == PlannerAlgorithm::kRiskRrtStar ? 2 : 0);
  }
}

// The same for a token cancelled before the run: the end reason is CANCELLED.
TEST(RunStopTest, ACancelledTokenStopsTheRunInsideItsFirstStep) {
  for (PlannerAlgorithm algorithm : {PlannerAlgorithm::kRiskRrtStar, PlannerAlgorithm::kGenetic}) {
    SCOPED_TRACE(PlannerAlgorithmName(algorithm));
    PlanOptions options;
    options.budget.max_iterations = 1000;
    options.budget.max_time_s = 0.0;
    CancellationToken cancel;
    cancel.Cancel();
    auto result = PlanFirstScenario(algorithm, options, cancel);
    ASSERT_TRUE(result.ok()) << result.status();
    EXPECT_EQ(result->reason, StopReason::kCancelled);
    EXPECT_EQ(result->tree_size, algorithm == PlannerAlgorithm::kRiskRrtStar ? 2 : 0);
  }
}

TEST(RunStopTest, RunStoppedIsRecognisedOnlyByItsMark) {
  EXPECT_TRUE(IsRunStopped(RunStopped()));
  EXPECT_EQ(RunStopped().code(), absl::StatusCode::kCancelled);
  EXPECT_FALSE(IsRunStopped(absl::CancelledError("an evaluator's own cancellation")));
  EXPECT_FALSE(IsRunStopped(absl::OkStatus()));
}

}  // namespace
}  // namespace riskplan
