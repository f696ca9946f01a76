#include "bench/ompl/ompl_runs.h"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <utility>

#include "bench/ompl/grid_nearest_neighbors.h"
#include "bench/ompl/risk_objective.h"
#include "bench/ompl/risk_state_space.h"
#include "core/flight/trajectory.h"
#include "ompl/base/PlannerData.h"
#include "ompl/base/ProblemDefinition.h"
#include "ompl/base/ScopedState.h"
#include "ompl/datastructures/NearestNeighborsLinear.h"
#include "ompl/datastructures/NearestNeighborsSqrtApprox.h"
#include "ompl/geometric/PathGeometric.h"
#include "ompl/geometric/planners/informedtrees/ABITstar.h"
#include "ompl/geometric/planners/informedtrees/BITstar.h"
#include "ompl/geometric/planners/rrt/InformedRRTstar.h"
#include "ompl/geometric/planners/rrt/RRTstar.h"
#include "ompl/util/RandomNumbers.h"

namespace riskplan::bench {
namespace {

namespace ob = ompl::base;
namespace og = ompl::geometric;

// The goal is reached only by the goal configuration itself (Dubins length
// to it below a micrometre), as RISK_RRT_STAR's trajectories end exactly there.
constexpr double kGoalThresholdM = 1e-6;

absl::Status ConfigureRrtStar(og::RRTstar* planner, const OmplSettings& s, bool informed) {
  planner->setRange(s.rrt_range_m);
  planner->setRewireFactor(s.rrt_rewire_factor);
  planner->setKNearest(s.rrt_k_nearest);
  planner->setGoalBias(s.rrt_goal_bias);
  if (informed) planner->setAdmissibleCostToCome(s.irrt_admissible_cost_to_come);
  GridNeighborsLayout().cell_m = s.grid_cell_m;
  // Each of these calls setup() (which needs the problem definition).
  if (s.rrt_nn == "grid") {
    planner->setNearestNeighbors<GridNearestNeighbors>();
  } else if (s.rrt_nn == "sqrtapprox") {
    planner->setNearestNeighbors<ompl::NearestNeighborsSqrtApprox>();
  } else if (s.rrt_nn == "linear") {
    planner->setNearestNeighbors<ompl::NearestNeighborsLinear>();
  } else {
    return absl::InvalidArgumentError("rrt_nn must be grid, sqrtapprox or linear, not '" +
                                      s.rrt_nn + "'");
  }
  return absl::OkStatus();
}

}  // namespace

bool IsOmplPlanner(const std::string& name) {
  return name == "RRTstar" || name == "InformedRRTstar" || name == "BITstar" || name == "ABITstar";
}

absl::StatusOr<RunRecord> RunOmplPlanner(const std::string& planner_name,
                                         std::shared_ptr<const RiskModel> model,
                                         const Scenario& scenario, uint64_t seed, double budget_s,
                                         const std::vector<double>& checkpoints_s,
                                         const OmplSettings& settings) {
  if (!IsOmplPlanner(planner_name)) {
    return absl::InvalidArgumentError("unknown OMPL planner '" + planner_name + "'");
  }
  ompl::RNG::setSeed(seed);
  const RiskModel& m = *model;
  const RiskMap& map = m.map();
  GridNeighborsLayout() =
      GridLayout{map.x0(), map.y0(), map.width_m(), map.height_m(), settings.grid_cell_m};

  auto space = std::make_shared<DubinsAirplaneSpace>(model);
  auto si = std::make_shared<ob::SpaceInformation>(space);
  si->setStateValidityChecker(std::make_shared<RiskValidityChecker>(si, m));
  si->setMotionValidator(std::make_shared<RiskMotionValidator>(si, m));
  si->setup();

  auto pdef = std::make_shared<ob::ProblemDefinition>(si);
  ob::ScopedState<> start(space);
  ob::ScopedState<> goal(space);
  DubinsAirplaneSpace::FromPose(scenario.start, start.get());
  DubinsAirplaneSpace::FromPose(scenario.goal, goal.get());
  pdef->setStartAndGoalStates(start, goal, kGoalThresholdM);
  auto objective = std::make_shared<RiskObjective>(si, m);
  pdef->setOptimizationObjective(objective);

  ob::PlannerPtr planner;
  std::function<int64_t()> iterations;
  if (planner_name == "BITstar" || planner_name == "ABITstar") {
    std::shared_ptr<og::BITstar> bit;
    if (planner_name == "ABITstar") {
      // ABIT*: BIT* searching each batch first with an inflated heuristic and
      // truncating the search. With h = 0 (RiskObjective) an inflated h is
      // still 0, so only the truncation changes anything here.
      auto abit = std::make_shared<og::ABITstar>(si);
      abit->setInitialInflationFactor(settings.abit_initial_inflation);
      abit->setInflationScalingParameter(settings.abit_inflation_scaling);
      abit->setTruncationScalingParameter(settings.abit_truncation_scaling);
      bit = abit;
    } else {
      bit = std::make_shared<og::BITstar>(si);
    }
    bit->setProblemDefinition(pdef);
    bit->setSamplesPerBatch(settings.bit_samples_per_batch);
    bit->setRewireFactor(settings.bit_rewire_factor);
    bit->setUseKNearest(settings.bit_k_nearest);
    // BIT*'s nearest-neighbour structure cannot be replaced from outside the
    // library in 1.5.2 (its setNearestNeighbors is not instantiated for other
    // types); as the space is not metric, OMPL picks NearestNeighborsSqrtApprox.
    iterations = [p = bit.get()] { return static_cast<int64_t>(p->numIterations()); };
    planner = bit;
  } else {
    const bool informed = planner_name == "InformedRRTstar";
    std::shared_ptr<og::RRTstar> rrt =
        informed ? std::make_shared<og::InformedRRTstar>(si) : std::make_shared<og::RRTstar>(si);
    rrt->setProblemDefinition(pdef);
    if (absl::Status s = ConfigureRrtStar(rrt.get(), settings, informed); !s.ok()) return s;
    iterations = [p = rrt.get()] { return static_cast<int64_t>(p->numIterations()); };
    planner = rrt;
  }
  if (!planner->isSetup()) planner->setup();

  RunRecord record;
  record.planner = planner_name;
  record.scenario = scenario.name;
  record.seed = seed;
  record.budget_s = budget_s;
  const auto t0 = std::chrono::steady_clock::now();
  auto elapsed = [&t0] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  pdef->setIntermediateSolutionCallback(
      [&](const ob::Planner*, const std::vector<const ob::State*>&, const ob::Cost cost) {
        record.improvements.push_back({elapsed(), cost.value(), iterations()});
      });
  size_t next_checkpoint = 0;
  // Evaluated once per planner iteration: also where the iteration count at
  // each checkpoint is read.
  ob::PlannerTerminationCondition ptc([&] {
    const double t = elapsed();
    while (next_checkpoint < checkpoints_s.size() && t >= checkpoints_s[next_checkpoint]) {
      record.checkpoint_iterations.push_back({checkpoints_s[next_checkpoint], iterations()});
      ++next_checkpoint;
    }
    return t >= budget_s;
  });
  const ob::PlannerStatus status = planner->solve(ptc);
  record.elapsed_s = elapsed();
  record.iterations = iterations();
  for (; next_checkpoint < checkpoints_s.size(); ++next_checkpoint) {
    record.checkpoint_iterations.push_back({checkpoints_s[next_checkpoint], record.iterations});
  }
  record.configurations = objective->configurations_evaluated();
  if (std::getenv("RISKPLAN_OMPL_DEBUG") != nullptr) {
    std::fprintf(stderr, "debug: space measure %.6g\n", si->getSpaceMeasure());
    std::fprintf(stderr, "debug: motionCost calls %llu, configurations %llu, motions checked %u\n",
                 static_cast<unsigned long long>(objective->edges_evaluated()),
                 static_cast<unsigned long long>(objective->configurations_evaluated()),
                 si->getMotionValidator()->getCheckedMotionCount());
  }
  ob::PlannerData data(si);
  planner->getPlannerData(data);
  record.vertices = data.numVertices();

  record.solved = status == ob::PlannerStatus::EXACT_SOLUTION && pdef->hasExactSolution();
  if (record.solved) {
    auto& path = static_cast<og::PathGeometric&>(*pdef->getSolutionPath());
    std::vector<Pose> waypoints;
    for (const ob::State* st : path.getStates()) {
      waypoints.push_back(DubinsAirplaneSpace::ToPose(st));
    }
    // The planner's own cost of its best solution.
    record.best_risk = pdef->getSolutions().front().cost_.value();
    auto pieces = PiecesFromWaypoints(waypoints, m.params());
    if (!pieces.ok()) return pieces.status();
    auto evaluation = EvaluateTrajectory(m, *pieces);
    if (!evaluation.ok()) return evaluation.status();
    record.reevaluated_risk = evaluation->risk;
    record.reevaluated_admissible = evaluation->admissible;
  }
  return record;
}

}  // namespace riskplan::bench
