#include "core/risk/risk_layer.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/map/demo_city.h"
#include "gtest/gtest.h"
#include "tests/core/test_maps.h"

namespace riskplan {
namespace {

// A map whose density, shelter and terrain change from cell to cell, with an
// origin away from (0, 0) and sides that no stride above 1 divides, so that a
// value computed anywhere but at its cell's centre, or a raster origin or cell
// size that does not match, shows.
std::shared_ptr<const RiskMap> IrregularMap(int nx = 101, int ny = 89, float high_terrain = 0.0f) {
  MapHeader header;
  header.name = "irregular";
  header.x0 = -250.0;
  header.y0 = 130.0;
  header.res = 5.0;
  header.nx = nx;
  header.ny = ny;
  MapLayers layers;
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      layers.density.push_back(0.001f * static_cast<float>((i * 7 + j * 13) % 11));
      layers.shelter.push_back(static_cast<float>((i * 3 + j * 5) % 10));
      // high_terrain > 0: the western five columns stand that high.
      layers.terrain.push_back(i < 5 && high_terrain > 0.0f ? high_terrain
                                                            : 200.0f + 3.0f * ((i + 2 * j) % 7));
      layers.nofly.push_back(0);
    }
  }
  auto map = RiskMap::Create(std::move(header), std::move(layers));
  EXPECT_TRUE(map.ok()) << map.status();
  return map.ok() ? *map : nullptr;
}

// M of the spec at (x, y), height_agl_m above the terrain of the cell holding
// (x, y), heading theta; NaN where undefined.
double DirectRisk(const RiskModel& model, double x, double y, double height_agl_m, double theta) {
  int i = 0;
  int j = 0;
  if (!model.map().CellOf(x, y, &i, &j)) return std::nan("");
  const ConfigurationRisk cr = model.Evaluate(
      Pose{x, y, static_cast<double>(model.map().terrain(i, j)) + height_agl_m, theta});
  return cr.defined ? cr.risk : std::nan("");
}

// Equal, or both NaN (NODATA).
::testing::AssertionResult SameValue(double a, double b) {
  if (a == b || (std::isnan(a) && std::isnan(b))) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << a << " vs " << b;
}

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
  int defined = 0;
  int nodata = 0;
  for (int j = 0; j < 100; j += 7) {
    for (int i = 0; i < 100; i += 3) {
      const double x = (i + 0.5) * 10.0;
      const double y = (j + 0.5) * 10.0;
      const double z = (*map)->terrain(i, j) + 80.0;
      const ConfigurationRisk cr = (*model)->Evaluate(Pose{x, y, z, 1.0});
      if (cr.defined) {
        EXPECT_EQ(layer->risk[j * 100 + i], cr.risk);
        ++defined;
      } else {
        // The impact window reaches past the map (spec version 2).
        EXPECT_TRUE(std::isnan(layer->risk[j * 100 + i]));
        ++nodata;
      }
    }
  }
  EXPECT_GT(defined, 200);
  EXPECT_GT(nodata, 20);
}

TEST(RiskLayerTest, StridedCellsHoldTheRiskAtTheCentreOfTheirBlock) {
  auto map = IrregularMap();
  ASSERT_NE(map, nullptr);
  auto model = RiskModel::Create(map, ModelParams{});
  ASSERT_TRUE(model.ok());
  const double theta = 2.0;
  auto fine = ComputeRiskLayer(**model, {.height_agl_m = 60.0, .heading_rad = theta});
  ASSERT_TRUE(fine.ok()) << fine.status();
  for (int stride : {2, 3, 4}) {
    SCOPED_TRACE(stride);
    auto layer =
        ComputeRiskLayer(**model, {.height_agl_m = 60.0, .heading_rad = theta, .stride = stride});
    ASSERT_TRUE(layer.ok()) << layer.status();
    // Whole blocks only: the raster never reaches past the map.
    EXPECT_EQ(layer->nx, 101 / stride);
    EXPECT_EQ(layer->ny, 89 / stride);
    EXPECT_EQ(layer->x0, -250.0);
    EXPECT_EQ(layer->y0, 130.0);
    EXPECT_EQ(layer->res_m, 5.0 * stride);
    EXPECT_LE(layer->x0 + layer->nx * layer->res_m, map->x0() + map->width_m());
    EXPECT_LE(layer->y0 + layer->ny * layer->res_m, map->y0() + map->height_m());
    EXPECT_EQ(layer->evaluations, int64_t{layer->nx} * layer->ny);
    int finite = 0;
    for (int r = 0; r < layer->ny; ++r) {
      for (int c = 0; c < layer->nx; ++c) {
        // The centre of block (c, r), from the map's own geometry.
        const double x = -250.0 + (c * stride + stride / 2.0) * 5.0;
        const double y = 130.0 + (r * stride + stride / 2.0) * 5.0;
        EXPECT_EQ(layer->centre_x(c), x);
        EXPECT_EQ(layer->centre_y(r), y);
        ASSERT_TRUE(SameValue(layer->at(c, r), DirectRisk(**model, x, y, 60.0, theta)))
            << c << ", " << r;
        finite += std::isfinite(layer->at(c, r)) ? 1 : 0;
        if (stride % 2 == 1) {
          // An odd block's centre is the centre of its middle map cell.
          EXPECT_TRUE(SameValue(layer->at(c, r),
                                fine->at(c * stride + stride / 2, r * stride + stride / 2)));
        }
      }
    }
    // Most of the map is inside the reach at 60 m (about 90 m from the edge).
    EXPECT_GT(finite, layer->nx * layer->ny / 3);
  }
}

TEST(RiskLayerTest, MaxOverHeadingsIsTheLargestOfAllHeadingBins) {
  auto map = MakeDemoCity({.size_m = 1000.0, .res_m = 10.0});
  ASSERT_TRUE(map.ok());
  auto model = RiskModel::Create(*map, ModelParams{});
  ASSERT_TRUE(model.ok());
  ASSERT_EQ((*model)->table().heading_bins(), 72);
  auto layer = ComputeRiskLayer(
      **model, {.height_agl_m = 120.0, .heading_rad = std::nan(""), .threads = 2, .stride = 5});
  ASSERT_TRUE(layer.ok()) << layer.status();
  ASSERT_EQ(layer->nx, 20);
  EXPECT_EQ(layer->evaluations, 20 * 20 * 72);
  int cells_where_east_is_not_the_max = 0;
  // The corners are NODATA: at 120 m the window reaches about 125 m.
  EXPECT_TRUE(std::isnan(layer->at(0, 0)));
  EXPECT_TRUE(std::isnan(layer->at(19, 19)));
  for (auto [c, r] : {std::pair{3, 3}, {3, 16}, {9, 10}, {10, 9}, {14, 4}, {16, 16}, {12, 12}}) {
    SCOPED_TRACE(::testing::Message() << c << ", " << r);
    const double x = layer->centre_x(c);
    const double y = layer->centre_y(r);
    double expected = -1.0;
    int argmax = -1;
    for (int degrees = 0; degrees < 360; degrees += 5) {
      const double m = DirectRisk(**model, x, y, 120.0, degrees * std::numbers::pi / 180.0);
      ASSERT_TRUE(std::isfinite(m));
      if (m > expected) {
        expected = m;
        argmax = degrees;
      }
    }
    EXPECT_EQ(layer->at(c, r), expected);
    if (argmax != 0) ++cells_where_east_is_not_the_max;
  }
  EXPECT_GE(cells_where_east_is_not_the_max, 3);  // the test tells the max from east
}

TEST(RiskLayerTest, ThreadsDoNotChangeTheResult) {
  auto map = MakeDemoCity({.size_m = 1000.0, .res_m = 10.0});
  ASSERT_TRUE(map.ok());
  auto model = RiskModel::Create(*map, ModelParams{});
  ASSERT_TRUE(model.ok());
  auto one = ComputeRiskLayer(**model, {.heading_rad = std::nan(""), .threads = 1, .stride = 3});
  auto three = ComputeRiskLayer(**model, {.heading_rad = std::nan(""), .threads = 3, .stride = 3});
  ASSERT_TRUE(one.ok() && three.ok());
  ASSERT_EQ(one->risk.size(), three->risk.size());
  for (size_t k = 0; k < one->risk.size(); ++k) {
    ASSERT_TRUE(SameValue(one->risk[k], three->risk[k])) << k;
  }
  EXPECT_EQ(one->nx, 33);
  EXPECT_EQ(one->evaluations, 33 * 33 * 72);
}

TEST(RiskLayerTest, UndefinedRiskIsNaNForOneHeadingAndForTheMaximum) {
  // 1e6 m + 1e-11 m rounds back to 1e6 m in double: h = 0 over the western
  // five columns, where the spec leaves M undefined; elsewhere h = 1e-11 m > 0.
  auto map = IrregularMap(40, 30, 1.0e6f);
  ASSERT_NE(map, nullptr);
  auto model = RiskModel::Create(map, ModelParams{});
  ASSERT_TRUE(model.ok());
  // The lowest height bin's window, and so the NODATA band along the edges,
  // reaches less than 10 cells (50 m).
  const ImpactReach reach = (*model)->Reach(1e-11);
  ASSERT_LT(reach.Max(), 10 * 5.0);
  for (double heading : {0.7, std::nan("")}) {
    SCOPED_TRACE(heading);
    auto layer = ComputeRiskLayer(**model, {.height_agl_m = 1e-11, .heading_rad = heading});
    ASSERT_TRUE(layer.ok()) << layer.status();
    int finite = 0;
    for (int r = 0; r < layer->ny; ++r) {
      for (int c = 0; c < layer->nx; ++c) {
        if (c < 5) {
          EXPECT_TRUE(std::isnan(layer->at(c, r))) << c << ", " << r << ": " << layer->at(c, r);
        } else if (c >= 10 && c < 30 && r >= 10 && r < 20) {
          EXPECT_TRUE(std::isfinite(layer->at(c, r))) << c << ", " << r;
          ++finite;
        }
      }
    }
    EXPECT_EQ(finite, 20 * 10);
  }
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
  auto map = testing_maps::UniformMap(10, 12, 5.0, 0.01f, 4.0f, 100.0f);
  auto model = RiskModel::Create(map, ModelParams{});
  ASSERT_TRUE(model.ok());
  EXPECT_FALSE(ComputeRiskLayer(**model, {.height_agl_m = 0.0}).ok());
  EXPECT_FALSE(ComputeRiskLayer(**model, {.heading_rad = INFINITY}).ok());
  EXPECT_FALSE(ComputeRiskLayer(**model, {.threads = 0}).ok());
  EXPECT_FALSE(ComputeRiskLayer(**model, {.stride = 0}).ok());
  EXPECT_TRUE(ComputeRiskLayer(**model, {.stride = 10}).ok());
  const auto too_wide = ComputeRiskLayer(**model, {.stride = 11});
  EXPECT_EQ(too_wide.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(too_wide.status().message(),
            "risk layer: stride 11 is larger than the map of 10 x 12 cells");
}

}  // namespace
}  // namespace riskplan
