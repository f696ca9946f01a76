// Risk layers over a window of the map (GetRiskLayer's regions), their shape
// known before any work (LayerCells), and a stop that ends the work.
#include <cmath>

#include "core/map/demo_city.h"
#include "core/risk/risk_layer.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace riskplan {
namespace {

using ::testing::HasSubstr;

std::shared_ptr<const RiskModel> DemoModel() {
  auto map = MakeDemoCity({.size_m = 1000.0, .res_m = 10.0});
  EXPECT_TRUE(map.ok()) << map.status();
  auto model = RiskModel::Create(*map, ModelParams{});
  EXPECT_TRUE(model.ok()) << model.status();
  return *model;
}

// A window's cells are the whole map's layer cells it covers, bit for bit,
// when the window starts on a multiple of the stride.
TEST(RiskLayerWindowTest, AWindowIsThePartOfTheWholeLayer) {
  const auto model = DemoModel();
  const RiskLayerOptions whole{.height_agl_m = 70.0, .heading_rad = 0.7, .stride = 2};
  auto all = ComputeRiskLayer(*model, whole);
  ASSERT_TRUE(all.ok()) << all.status();
  RiskLayerOptions part = whole;
  part.first_column = 30;
  part.first_row = 44;
  part.columns = 25;  // 12 whole blocks; the last column is left out
  part.rows = 20;
  auto window = ComputeRiskLayer(*model, part);
  ASSERT_TRUE(window.ok()) << window.status();
  EXPECT_EQ(window->nx, 12);
  EXPECT_EQ(window->ny, 10);
  EXPECT_EQ(window->x0, 300.0);
  EXPECT_EQ(window->y0, 440.0);
  EXPECT_EQ(window->res_m, 20.0);
  EXPECT_EQ(window->evaluations, 120);
  for (int r = 0; r < window->ny; ++r) {
    for (int c = 0; c < window->nx; ++c) {
      const double a = window->at(c, r), b = all->at(c + 15, r + 22);
      EXPECT_TRUE(a == b || (std::isnan(a) && std::isnan(b))) << c << ", " << r;
    }
  }
  auto shape = LayerCells(model->map(), part);
  ASSERT_TRUE(shape.ok());
  EXPECT_EQ(shape->nx, 12);
  EXPECT_EQ(shape->ny, 10);
}

TEST(RiskLayerWindowTest, WindowsOutsideTheMapAndStridesPastThemAreRefused) {
  const auto model = DemoModel();
  RiskLayerOptions o{.height_agl_m = 70.0, .heading_rad = 0.0};
  o.first_column = 90;
  o.columns = 11;  // to column 101 of 100
  EXPECT_THAT(LayerCells(model->map(), o).status().message(),
              HasSubstr("the window of columns [90, 101) and rows [0, 100) is not inside the map "
                        "of 100 x 100 cells"));
  o.columns = 10;
  o.stride = 11;
  EXPECT_THAT(ComputeRiskLayer(*model, o).status().message(),
              HasSubstr("stride 11 is larger than the window of 10 x 100 cells"));
  o.first_row = -1;
  EXPECT_EQ(LayerCells(model->map(), o).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(RiskLayerWindowTest, AReachedStopEndsTheWork) {
  const auto model = DemoModel();
  CancellationToken token;
  token.Cancel();
  RiskLayerOptions o{.height_agl_m = 70.0, .heading_rad = std::nan(""), .threads = 2};
  o.stop = StopCondition(&token);
  auto layer = ComputeRiskLayer(*model, o);
  EXPECT_EQ(layer.status().code(), absl::StatusCode::kCancelled);
}

}  // namespace
}  // namespace riskplan
