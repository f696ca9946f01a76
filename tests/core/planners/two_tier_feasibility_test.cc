#include "core/planners/two_tier_feasibility.h"

#include <cmath>
#include <vector>

#include "core/base/random.h"
#include "core/flight/trajectory.h"
#include "gtest/gtest.h"
#include "tests/core/obstacle_test_maps.h"
#include "tests/core/planner_test_util.h"

namespace riskplan {
namespace {

using testing_maps::SyntheticModel;

// The exact check of a polyline: spec section 6 on EvaluateTrajectory's
// samples of its straight segments.
bool ExactlyAdmissible(const RiskModel& model, const std::vector<Point3>& path) {
  auto pieces = PiecesFromPolyline(path);
  EXPECT_TRUE(pieces.ok());
  auto eval = EvaluateTrajectory(model, *pieces);
  EXPECT_TRUE(eval.ok());
  return eval->admissible;
}

// The same samples under seed 001's rule alone: inside the map, above terrain.
bool AboveTerrain(const RiskModel& model, const std::vector<Point3>& path) {
  auto pieces = PiecesFromPolyline(path);
  for (const TrajectoryPiece& piece : *pieces) {
    std::vector<Pose> samples = {piece.Start(), piece.End()};
    AppendMidpoints(piece, model.params().sample_step_m, &samples);
    for (const Pose& q : samples) {
      int i = 0, j = 0;
      if (!model.map().CellOf(q.x, q.y, &i, &j) || q.z <= model.map().terrain(i, j)) return false;
    }
  }
  return true;
}

// Random polylines of 2 or 3 segments over demo-city, 20 m to 1.5 km long,
// at altitudes around the flight band, so that about half pass.
std::vector<std::vector<Point3>> RandomPaths(const RiskModel& model, int n, uint64_t seed) {
  Rng rng(seed);
  std::vector<std::vector<Point3>> out;
  const RiskMap& map = model.map();
  while (static_cast<int>(out.size()) < n) {
    std::vector<Point3> path;
    double x = 100.0 + rng.Uniform() * 7800.0;
    double y = 100.0 + rng.Uniform() * 7800.0;
    const int points = 3 + static_cast<int>(rng.Below(2));
    for (int k = 0; k < points; ++k) {
      int i = 0, j = 0;
      if (!map.CellOf(x, y, &i, &j)) break;
      path.push_back({x, y, map.terrain(i, j) + 20.0 + 160.0 * rng.Uniform()});
      const double length = 20.0 + rng.Uniform() * 1480.0;
      const double heading = rng.Uniform() * kTwoPi;
      x += length * std::cos(heading);
      y += length * std::sin(heading);
    }
    if (path.size() >= 2) out.push_back(std::move(path));
  }
  return out;
}

TEST(TwoTierFeasibilityTest, NeverFeasibleWhereTheExactCheckRejects) {
  const auto model = testing_planner::DemoCityModel();
  const auto paths = RandomPaths(*model, 3000, 1);
  for (int detailed : {100, 0, 2}) {
    SCOPED_TRACE(detailed);
    const TwoTierFeasibility band(*model, {CollisionRule::kFlightBand, detailed});
    const TwoTierFeasibility terrain(*model, {CollisionRule::kTerrain, detailed});
    int feasible = 0;
    int conservative = 0;  // rejected by the checker, admissible exactly
    for (const auto& path : paths) {
      const bool exact = ExactlyAdmissible(*model, path);
      const FeasibilityResult r = band.CheckPath(path);
      if (r.feasible) {
        ++feasible;
        ASSERT_TRUE(exact) << "a feasible path that the exact check rejects";
      } else if (exact) {
        ++conservative;
      }
      if (terrain.CheckPath(path).feasible) {
        ASSERT_TRUE(AboveTerrain(*model, path));
      }
    }
    EXPECT_GT(feasible, 300);
    if (detailed == 100) {
      // The detailed tier rejects an exactly admissible path only where the
      // segment crosses a cell between two samples (5 m apart): rarely.
      EXPECT_LT(conservative, feasible / 10);
    }
  }
}

TEST(TwoTierFeasibilityTest, TrajectoriesAreCheckedAlongTheirSamples) {
  const auto model = testing_planner::DemoCityModel();
  const TwoTierFeasibility checker(*model, {CollisionRule::kFlightBand, 2});
  Rng rng(2);
  int feasible = 0;
  for (int n = 0; n < 400; ++n) {
    std::vector<Pose> waypoints;
    for (int k = 0; k < 4; ++k) {
      const double x = 500.0 + rng.Uniform() * 7000.0, y = 500.0 + rng.Uniform() * 7000.0;
      int i = 0, j = 0;
      model->map().CellOf(x, y, &i, &j);
      waypoints.push_back({x, y, model->map().terrain(i, j) + 40.0 + 100.0 * rng.Uniform(),
                           rng.Uniform() * kTwoPi});
    }
    auto pieces = PiecesFromWaypoints(waypoints, model->params());
    const FeasibilityResult r = checker.CheckTrajectory(*pieces);
    auto eval = EvaluateTrajectory(*model, *pieces);
    if (r.feasible) {
      ++feasible;
      ASSERT_TRUE(eval->admissible);
    } else if (!eval->admissible && r.tier == FeasibilityTier::kDetailed) {
      // The detailed tier finds the exact check's first violation's piece.
      EXPECT_EQ(r.segment, eval->first_violation->piece);
    }
  }
  EXPECT_GT(feasible, 10);
}

// One high cell in a flat map: a path beside it, in the same 16 x 16 block,
// passes the detailed tier but not the coarse one.
TEST(TwoTierFeasibilityTest, CoarseTierIsConservative) {
  const auto model =
      SyntheticModel("spike", 64, 64, 10.0, nullptr, nullptr, [](double x, double y) {
        return (x > 200.0 && x < 210.0 && y > 200.0 && y < 210.0) ? 300.0f : 100.0f;
      });
  const std::vector<Point3> path = {{5.0, 250.0, 200.0}, {600.0, 250.0, 200.0}};
  const TwoTierFeasibility detailed(*model, {CollisionRule::kTerrain, 1});
  const TwoTierFeasibility coarse(*model, {CollisionRule::kTerrain, 0});
  EXPECT_TRUE(detailed.CheckPath(path).feasible);
  EXPECT_TRUE(AboveTerrain(*model, path));
  const FeasibilityResult r = coarse.CheckPath(path);
  EXPECT_FALSE(r.feasible);
  EXPECT_EQ(r.tier, FeasibilityTier::kCoarse);
  EXPECT_EQ(r.kind, ViolationKind::kTerrainCollision);
  EXPECT_EQ(r.cell_i, 1);  // block [160, 320) m
  EXPECT_EQ(r.cell_j, 1);
  EXPECT_DOUBLE_EQ(r.position.x, 160.0);
  // Over the spike itself both tiers see it.
  const std::vector<Point3> over = {{5.0, 205.0, 200.0}, {600.0, 205.0, 200.0}};
  EXPECT_EQ(detailed.CheckPath(over).tier, FeasibilityTier::kDetailed);
}

TEST(TwoTierFeasibilityTest, ReportsWhichTierAndSegmentFoundTheCollision) {
  // 1 km square; routes keep 250 m from the edges, beyond the margins where a
  // fall's impact window may reach past the map.
  const auto model = SyntheticModel("spike", 100, 100, 10.0, [](double x, double y) {
    return x > 600.0 && x < 620.0 && y > 600.0 && y < 620.0;  // no-fly
  });
  const TwoTierFeasibility checker(*model, {CollisionRule::kFlightBand, 2});
  // Segments 0 and 1 clear; segment 2 crosses the no-fly square.
  std::vector<Point3> path = {
      {250.0, 250.0, 190.0}, {250.0, 500.0, 190.0}, {500.0, 500.0, 190.0}, {700.0, 700.0, 190.0}};
  FeasibilityResult r = checker.CheckPath(path);
  EXPECT_FALSE(r.feasible);
  EXPECT_EQ(r.tier, FeasibilityTier::kCoarse);
  EXPECT_EQ(r.segment, 2);
  EXPECT_EQ(r.kind, ViolationKind::kBelowSafeAltitude);  // the block's pooled floor
  EXPECT_GT(r.cells_checked, 50);
  // The same square crossed by the first segment: the detailed tier, exactly.
  path = {{500.0, 500.0, 190.0}, {700.0, 700.0, 190.0}};
  r = checker.CheckPath(path);
  EXPECT_EQ(r.tier, FeasibilityTier::kDetailed);
  EXPECT_EQ(r.segment, 0);
  EXPECT_EQ(r.kind, ViolationKind::kNoFlyZone);
  EXPECT_EQ(r.cell_i, 60);
  EXPECT_EQ(r.cell_j, 60);
  // Too high, and outside the map.
  r = checker.CheckPath(std::vector<Point3>{{250.0, 250.0, 190.0}, {300.0, 250.0, 260.0}});
  EXPECT_EQ(r.kind, ViolationKind::kAboveMaxAltitude);
  r = checker.CheckPath(std::vector<Point3>{{250.0, 250.0, 190.0}, {-10.0, 250.0, 190.0}});
  EXPECT_EQ(r.kind, ViolationKind::kOutsideMap);
  // Towards the west edge at 90 m above the ground: the first cell whose
  // ceiling for the impact window is below 90 m, before the edge itself.
  r = checker.CheckPath(std::vector<Point3>{{250.0, 250.0, 190.0}, {5.0, 250.0, 190.0}});
  EXPECT_EQ(r.tier, FeasibilityTier::kDetailed);
  EXPECT_EQ(r.kind, ViolationKind::kImpactOutsideMap);
  EXPECT_GT(r.cell_i, 0);
  EXPECT_LT(model->WindowCeilingAgl(r.cell_i, r.cell_j), 90.0);
  EXPECT_GE(model->WindowCeilingAgl(r.cell_i + 1, r.cell_j), 90.0);
  // Lower, the same path flies closer to the edge.
  const FeasibilityResult low =
      checker.CheckPath(std::vector<Point3>{{250.0, 250.0, 135.0}, {5.0, 250.0, 135.0}});
  EXPECT_EQ(low.kind, ViolationKind::kImpactOutsideMap);
  EXPECT_LT(low.cell_i, r.cell_i);
  // Counting every colliding cell.
  path = {{500.0, 610.0, 190.0}, {700.0, 610.0, 190.0}};
  EXPECT_EQ(checker.CheckPath(path, /*count_all=*/true).colliding_cells, 2);
  EXPECT_EQ(checker.CheckPath(path).colliding_cells, 1);
}

// Seed 001's one-cell-per-step Bresenham misses the cells that a segment only
// clips at a corner; an exact-check sample can lie in such a cell.
TEST(TwoTierFeasibilityTest, PlainBresenhamCanMissWhatTheExactCheckRejects) {
  const auto model =
      SyntheticModel("spike", 64, 64, 10.0, nullptr, nullptr, [](double x, double y) {
        return (x > 300.0 && x < 310.0 && y > 300.0 && y < 310.0) ? 300.0f : 100.0f;
      });
  const TwoTierFeasibility bresenham(*model,
                                     {CollisionRule::kTerrain, 1, 16, CellTraversal::kBresenham});
  const TwoTierFeasibility supercover(*model, {CollisionRule::kTerrain, 1});
  Rng rng(3);
  int missed = 0;
  for (int n = 0; n < 20000 && missed == 0; ++n) {
    const Point3 a{250.0 + 40.0 * rng.Uniform(), 250.0 + 40.0 * rng.Uniform(), 200.0};
    const Point3 b{320.0 + 40.0 * rng.Uniform(), 320.0 + 40.0 * rng.Uniform(), 200.0};
    const std::vector<Point3> path = {a, b};
    const bool exact = AboveTerrain(*model, path);
    if (!exact) {
      ASSERT_FALSE(supercover.CheckPath(path).feasible);
    }
    if (!exact && bresenham.CheckPath(path).feasible) ++missed;
  }
  EXPECT_GT(missed, 0);
}

TEST(TwoTierFeasibilityTest, OptionsAreChecked) {
  EXPECT_TRUE(CheckTwoTierOptions({}).ok());
  TwoTierOptions bad;
  bad.detailed_segments = -1;
  EXPECT_EQ(CheckTwoTierOptions(bad).code(), absl::StatusCode::kInvalidArgument);
  bad = {};
  bad.block_cells = 0;
  EXPECT_NE(CheckTwoTierOptions(bad).message().find("block_cells"), std::string::npos);
  EXPECT_EQ(FeasibilityTierName(FeasibilityTier::kCoarse), "COARSE");
}

}  // namespace
}  // namespace riskplan
