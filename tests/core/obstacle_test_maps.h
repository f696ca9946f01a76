// Synthetic maps with known answers for the tests of the seeds' planners
// (RRT, GENETIC, HARMONIC): a corridor, a wall with one gap, and a goal
// behind an obstacle. Flat terrain at 100 m, 10 m cells, no landing sites, so
// that the admissible band is [130, 250] m AMSL everywhere outside the no-fly
// cells; poses fly at 190 m.
#ifndef RISKPLAN_TESTS_CORE_OBSTACLE_TEST_MAPS_H_
#define RISKPLAN_TESTS_CORE_OBSTACLE_TEST_MAPS_H_

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/flight/trajectory.h"
#include "core/map/risk_map.h"
#include "core/planners/planner.h"
#include "core/risk/risk_model.h"
#include "gtest/gtest.h"

namespace riskplan::testing_maps {

inline constexpr double kTerrainM = 100.0;
inline constexpr double kFlightZM = 190.0;

// A model of nx x ny cells of `res` metres; no-fly where blocked(x, y) at the
// cell centre; density(x, y) people/m^2 (1e-4 when null); terrain(x, y) m
// AMSL (kTerrainM when null).
inline std::shared_ptr<const RiskModel> SyntheticModel(
    const std::string& name, int nx, int ny, double res,
    const std::function<bool(double, double)>& blocked,
    const std::function<float(double, double)>& density = nullptr,
    const std::function<float(double, double)>& terrain = nullptr) {
  MapHeader header;
  header.name = name;
  header.res = res;
  header.nx = nx;
  header.ny = ny;
  header.provenance = "test";
  MapLayers layers;
  const size_t n = static_cast<size_t>(nx) * ny;
  layers.density.assign(n, 1e-4f);
  layers.shelter.assign(n, 5.0f);
  layers.terrain.assign(n, static_cast<float>(kTerrainM));
  layers.nofly.assign(n, 0);
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const double x = (i + 0.5) * res;
      const double y = (j + 0.5) * res;
      const size_t k = static_cast<size_t>(j) * nx + i;
      if (blocked && blocked(x, y)) layers.nofly[k] = 1;
      if (density) layers.density[k] = density(x, y);
      if (terrain) layers.terrain[k] = terrain(x, y);
    }
  }
  auto map = RiskMap::Create(std::move(header), std::move(layers));
  EXPECT_TRUE(map.ok()) << map.status();
  auto model = RiskModel::Create(*map, ModelParams{});
  EXPECT_TRUE(model.ok()) << model.status();
  return *model;
}

// A problem on one of the maps below, with what the answer must satisfy.
struct KnownAnswerMap {
  std::shared_ptr<const RiskModel> model;
  Pose start;
  Pose goal;
};

// 2400 m x 800 m; only the corridor y in [250, 550] can be flown. Start near
// the west end, goal near the east end, both heading east, 250 m from the
// edges (a fall's impact window must stay inside the map, and the planners'
// whole-cell margins for it are up to 150 m wide on these maps).
inline KnownAnswerMap Corridor() {
  return {SyntheticModel("corridor", 240, 80, 10.0,
                         [](double, double y) { return y < 250.0 || y > 550.0; }),
          Pose{250.0, 400.0, kFlightZM, 0.0}, Pose{2150.0, 400.0, kFlightZM, 0.0}};
}

// 2000 m x 2000 m; a no-fly wall x in [950, 1050] with one gap, y in
// [1300, 1600]. Start west of the wall, goal east of it.
inline constexpr double kGapLowM = 1300.0;
inline constexpr double kGapHighM = 1600.0;
inline KnownAnswerMap WallWithGap() {
  return {SyntheticModel("wall-gap", 200, 200, 10.0,
                         [](double x, double y) {
                           return x > 950.0 && x < 1050.0 && !(y > kGapLowM && y < kGapHighM);
                         }),
          Pose{300.0, 600.0, kFlightZM, 0.0}, Pose{1700.0, 600.0, kFlightZM, 0.0}};
}

// 2000 m x 2000 m; a no-fly square [700, 1300]^2 between the start (west) and
// the goal (east).
inline KnownAnswerMap GoalBehindObstacle() {
  return {SyntheticModel("behind", 200, 200, 10.0,
                         [](double x, double y) {
                           return x > 700.0 && x < 1300.0 && y > 700.0 && y < 1300.0;
                         }),
          Pose{250.0, 1000.0, kFlightZM, 0.0}, Pose{1750.0, 1000.0, kFlightZM, 0.0}};
}

// The samples of spec section 4 (midpoints) of a waypoint trajectory.
inline std::vector<Pose> TrajectorySamples(const RiskModel& model,
                                           const std::vector<Pose>& waypoints) {
  std::vector<Pose> out;
  auto pieces = PiecesFromWaypoints(waypoints, model.params());
  EXPECT_TRUE(pieces.ok());
  for (const TrajectoryPiece& piece : *pieces) {
    AppendMidpoints(piece, model.params().sample_step_m, &out);
  }
  return out;
}

// EvaluateTrajectory of waypoints.
inline TrajectoryEvaluation Reevaluate(const RiskModel& model, const std::vector<Pose>& waypoints) {
  auto pieces = PiecesFromWaypoints(waypoints, model.params());
  EXPECT_TRUE(pieces.ok());
  auto eval = EvaluateTrajectory(model, *pieces);
  EXPECT_TRUE(eval.ok());
  return *eval;
}

}  // namespace riskplan::testing_maps

#endif  // RISKPLAN_TESTS_CORE_OBSTACLE_TEST_MAPS_H_
