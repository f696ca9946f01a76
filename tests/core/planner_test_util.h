// Shared set-up for planner tests on demo-city, and checks of the
// trajectories planners return.
#ifndef RISKPLAN_TESTS_CORE_PLANNER_TEST_UTIL_H_
#define RISKPLAN_TESTS_CORE_PLANNER_TEST_UTIL_H_

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "bench/scenarios.h"
#include "core/flight/piece_risk.h"
#include "core/flight/trajectory.h"
#include "core/map/demo_city.h"
#include "core/planners/planner.h"
#include "core/risk/risk_model.h"
#include "gtest/gtest.h"

namespace riskplan::testing_planner {

using bench::FindFlyablePose;
using bench::FlyablePose;
using bench::Scenario;

// demo-city with default parameters, built once per test program.
inline std::shared_ptr<const RiskModel> DemoCityModel() {
  static std::shared_ptr<const RiskModel> model = [] {
    auto map = MakeDemoCity();
    EXPECT_TRUE(map.ok()) << map.status();
    auto m = RiskModel::Create(*map, ModelParams{});
    EXPECT_TRUE(m.ok()) << m.status();
    return *m;
  }();
  return model;
}

// A 2 km demo-city with a wind of `wind_mps` blowing from `from_deg` (0:
// still air), for the lattice, bound and guide tests.
inline std::shared_ptr<const RiskModel> SmallCityModel(double wind_mps, double from_deg) {
  auto map = MakeDemoCity(DemoCityOptions{.size_m = 2000.0});
  EXPECT_TRUE(map.ok()) << map.status();
  ModelParams params;
  params.wind_speed_mps = wind_mps;
  params.wind_from_deg = from_deg;
  auto model = RiskModel::Create(*map, params);
  EXPECT_TRUE(model.ok()) << model.status();
  return *model;
}

// `model` with every cell whose centre lies within r of (x, y) closed, made
// as a Fly session makes its model of the moment (RiskMap::WithNoFly, the
// other layers shared; RiskModel::WithMap, the glide layer repaired).
inline std::shared_ptr<const RiskModel> WithClosedDisc(const RiskModel& model, double x, double y,
                                                       double r) {
  const RiskMap& map = model.map();
  std::vector<uint8_t> nofly = map.nofly_layer();
  for (int j = 0; j < map.ny(); ++j) {
    for (int i = 0; i < map.nx(); ++i) {
      const double cx = map.x0() + (i + 0.5) * map.res();
      const double cy = map.y0() + (j + 0.5) * map.res();
      if (std::hypot(cx - x, cy - y) <= r) nofly[map.Index(i, j)] = 1;
    }
  }
  auto closed = RiskMap::WithNoFly(model.map_ptr(), std::move(nofly));
  EXPECT_TRUE(closed.ok()) << closed.status();
  auto out = RiskModel::WithMap(model, *closed);
  EXPECT_TRUE(out.ok()) << out.status();
  return *out;
}

// The shared scenario set (bench/scenarios.h), with every pose found.
inline std::vector<Scenario> DemoCityScenarios(const RiskModel& model) {
  std::vector<Scenario> out = bench::DemoCityScenarios(model);
  EXPECT_GE(out.size(), 24u);
  return out;
}

// A test suite on demo-city: its model and the shared scenario set, made once
// per suite.
class DemoCityPlannerTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    model_ = DemoCityModel();
    scenarios_ = DemoCityScenarios(*model_);
  }
  inline static std::shared_ptr<const RiskModel> model_;
  inline static std::vector<Scenario> scenarios_;
};

// The risk an independent EvaluateTrajectory gives `waypoints`, and in
// `*admissible` whether it finds them admissible.
inline double ReEvaluate(const RiskModel& model, const std::vector<Pose>& waypoints,
                         bool* admissible) {
  auto pieces = PiecesFromWaypoints(waypoints, model.params());
  EXPECT_TRUE(pieces.ok());
  auto eval = EvaluateTrajectory(model, *pieces);
  EXPECT_TRUE(eval.ok());
  *admissible = eval->admissible;
  return eval->risk;
}

// Spec version 2: every admissibility sample of every piece of `waypoints`
// has its impact window wholly inside the map, computed here from the impact
// table and the map alone (version 3: at the air heading's bin, with the
// wind's offset). Adds the number of samples checked to `*samples`.
inline void ExpectImpactWindowsInside(const RiskModel& model, const std::vector<Pose>& waypoints,
                                      int64_t* samples) {
  auto pieces = PiecesFromWaypoints(waypoints, model.params());
  ASSERT_TRUE(pieces.ok());
  const RiskMap& map = model.map();
  const ImpactTable& t = model.table();
  for (const TrajectoryPiece& piece : *pieces) {
    const PieceRisk rule(piece, model.params().sample_step_m, model.params());
    for (int64_t s = 0; s < rule.admissibility_samples(); ++s) {
      const Pose q = rule.AdmissibilitySample(s);
      int i = 0, j = 0;
      ASSERT_TRUE(map.CellOf(q.x, q.y, &i, &j));
      const double h = q.z - map.terrain(i, j);
      ASSERT_GT(h, 0.0);
      const ImpactKernel& k =
          t.kernel(t.HeightBinOf(h), t.HeadingBinOf(model.wind().AirHeading(q.theta)));
      const int ci = static_cast<int>(std::floor((q.x + k.offset_x_m - map.x0()) / map.res()));
      const int cj = static_cast<int>(std::floor((q.y + k.offset_y_m - map.y0()) / map.res()));
      ASSERT_GE(ci - k.half_width, 0) << "sample at " << q.x << ", " << q.y;
      ASSERT_GE(cj - k.half_width, 0) << "sample at " << q.x << ", " << q.y;
      ASSERT_LT(ci + k.half_width, map.nx()) << "sample at " << q.x << ", " << q.y;
      ASSERT_LT(cj + k.half_width, map.ny()) << "sample at " << q.x << ", " << q.y;
      ++*samples;
    }
  }
}

}  // namespace riskplan::testing_planner

#endif  // RISKPLAN_TESTS_CORE_PLANNER_TEST_UTIL_H_
