// A plan served through a board gives the CPU path's trajectory wherever the
// board's rounding does not flip one of the planner's comparisons.
//
// How this is tested: the planner is deterministic given the risks it is
// handed, so a trajectory can only change where a comparison of two risk
// totals (best parent, rewiring, best solution) comes out differently. With
// the `precise` number format (w48m48a128) the board's error is about 1e-13
// relative, far below the gaps between the totals the planner compares, so
// every scenario must give the CPU's trajectory waypoint for waypoint (its
// risk within 1e-9). With the `board` format (w32m32a80, errors up to about
// 1e-6 relative) comparisons closer than that may flip; the test reports on
// how many scenarios the trajectories still match and checks that every plan
// completes with an admissible trajectory of comparable risk.
#include <cmath>
#include <iostream>
#include <memory>
#include <vector>

#include "accel/risk_engine.h"
#include "accel_test_util.h"
#include "plan_test_util.h"
#include "core/planner.h"
#include "core/trajectory.h"
#include "gtest/gtest.h"

namespace riskplan::accel {
namespace {

using testing::PlanWith;
using testing::Problems;
using testing::SameWaypoints;
using testing::ShimProcess;

// Plans every problem on the CPU and through a board with `format`; returns
// how many trajectories match.
int CompareWithBoard(const std::string& format, bool require_all) {
  auto shim = ShimProcess::Start({"--device=model", "--format=" + format});
  EXPECT_NE(shim, nullptr);
  if (shim == nullptr) return 0;
  RiskEngineOptions options;
  options.cpu_workers = 0;
  options.caller_runs = false;  // every batch to the board
  options.fpga_shims = {shim->endpoint()};
  auto engine = RiskEngine::Create(options);
  EXPECT_TRUE(engine.ok());
  EXPECT_TRUE(
      testing::WaitFor([&] { return (*engine)->Stats().fpga[0].state == WorkerState::kUp; }));
  const std::vector<PlanningProblem> problems = Problems();
  EXPECT_GE(problems.size(), 6u);
  int matches = 0;
  for (size_t p = 0; p < problems.size(); ++p) {
    auto cpu = PlanWith(nullptr, problems[p]);
    std::unique_ptr<RiskEvaluator> evaluator = (*engine)->NewEvaluator();
    auto board = PlanWith(evaluator.get(), problems[p]);
    EXPECT_TRUE(cpu.ok() && board.ok());
    if (!cpu.ok() || !board.ok()) continue;
    const bool same = SameWaypoints(*cpu, *board);
    matches += same;
    if (require_all) {
      EXPECT_TRUE(same) << "scenario " << p;
    }
    if (cpu->best && board->best) {
      // The board's trajectory re-evaluated on the CPU: admissible, and its
      // risk close to what the board reported.
      auto pieces = PiecesFromWaypoints(board->best->waypoints, problems[p].model->params());
      EXPECT_TRUE(pieces.ok()) << pieces.status();
      if (!pieces.ok()) continue;
      auto exact = EvaluateTrajectory(*problems[p].model, *pieces);
      EXPECT_TRUE(exact.ok());
      if (exact.ok()) {
        EXPECT_TRUE(exact->admissible) << "scenario " << p;
        const double tolerance = require_all ? 1e-9 : 1e-5;
        EXPECT_NEAR(exact->risk, board->best->risk, tolerance * exact->risk) << "scenario " << p;
        if (same) {
          EXPECT_NEAR(board->best->risk, cpu->best->risk, tolerance * cpu->best->risk);
        }
      }
    }
  }
  // Every batch went to the board.
  EXPECT_EQ((*engine)->Stats().caller_configurations, 0u);
  std::cout << "format " << format << ": " << matches << " of " << problems.size()
            << " trajectories identical to the CPU path\n";
  return matches;
}

TEST(PlanThroughShimTest, PreciseFormatGivesTheCpuTrajectories) {
  CompareWithBoard("precise", /*require_all=*/true);
}

TEST(PlanThroughShimTest, BoardFormatPlansCompleteAndMostlyMatch) {
  CompareWithBoard("board", /*require_all=*/false);
}

}  // namespace
}  // namespace riskplan::accel
