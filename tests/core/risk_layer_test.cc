#include "core/risk_layer.h"

#include <cmath>

#include "core/demo_city.h"
#include "gtest/gtest.h"
#include "tests/core/test_maps.h"

namespace riskplan {
namespace {

TEST(RiskLayerTest, EveryCellIsTheConfigurationRiskAtItsCentre) {
  auto map = MakeDemoCity({.size_m = 1000.0, .res_m = 10.0});
  ASSERT_TRUE(map.ok()) << map.status();
  auto model = RiskModel::Create(*map, ModelParams{});
  ASSERT_TRUE(model.ok());
  auto layer = ComputeRiskLayer(**model, {.height_agl_m = 80.0, .heading_rad = 1.0});
  ASSERT_TRUE(layer.ok()) << layer.status();
  ASSERT_EQ(layer->nx, 100);
  ASSERT_EQ(layer->ny, 100);
  EXPECT_EQ(layer->evaluations, 10000);
  for (int j = 0; j < 100; j += 7) {
    for (int i = 0; i < 100; i += 3) {
      const double x = (i + 0.5) * 10.0;
      const double y = (j + 0.5) * 10.0;
      const double z = (*map)->terrain(i, j) + 80.0;
      EXPECT_EQ(layer->risk[j * 100 + i], (*model)->Evaluate(Pose{x, y, z, 1.0}).risk);
    }
  }
}

TEST(RiskLayerTest, ThreadsDoNotChangeTheResultAndMaxBoundsEveryHeading) {
  auto map = MakeDemoCity({.size_m = 1000.0, .res_m = 10.0});
  ASSERT_TRUE(map.ok());
  auto model = RiskModel::Create(*map, ModelParams{});
  ASSERT_TRUE(model.ok());
  auto one = ComputeRiskLayer(**model, {.heading_rad = std::nan(""), .threads = 1, .stride = 3});
  auto three = ComputeRiskLayer(**model, {.heading_rad = std::nan(""), .threads = 3, .stride = 3});
  ASSERT_TRUE(one.ok() && three.ok());
  EXPECT_EQ(one->risk, three->risk);
  EXPECT_EQ(one->nx, 34);
  EXPECT_EQ(one->evaluations, 34 * 34 * 72);
  auto east = ComputeRiskLayer(**model, {.heading_rad = 0.0, .stride = 3});
  ASSERT_TRUE(east.ok());
  for (size_t n = 0; n < one->risk.size(); ++n) EXPECT_GE(one->risk[n], east->risk[n]);
}

TEST(RiskLayerTest, UniformMapGivesAUniformLayerAwayFromTheBorder) {
  auto map = testing_maps::UniformMap(60, 60, 5.0, 0.01f, 4.0f, 100.0f);
  auto model = RiskModel::Create(map, ModelParams{});
  ASSERT_TRUE(model.ok());
  auto layer = ComputeRiskLayer(**model, {.height_agl_m = 50.0, .heading_rad = 0.5});
  ASSERT_TRUE(layer.ok());
  const double centre = layer->risk[30 * 60 + 30];
  EXPECT_GT(centre, 0.0);
  EXPECT_NEAR(layer->risk[25 * 60 + 28], centre, 1e-15 * centre);
}

TEST(RiskLayerTest, BadOptionsAreRefused) {
  auto map = testing_maps::UniformMap(10, 10, 5.0, 0.01f, 4.0f, 100.0f);
  auto model = RiskModel::Create(map, ModelParams{});
  ASSERT_TRUE(model.ok());
  EXPECT_FALSE(ComputeRiskLayer(**model, {.height_agl_m = 0.0}).ok());
  EXPECT_FALSE(ComputeRiskLayer(**model, {.heading_rad = INFINITY}).ok());
  EXPECT_FALSE(ComputeRiskLayer(**model, {.threads = 0}).ok());
  EXPECT_FALSE(ComputeRiskLayer(**model, {.stride = 0}).ok());
}

}  // namespace
}  // namespace riskplan
