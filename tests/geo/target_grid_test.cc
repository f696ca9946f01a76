#include "geo/target_grid.h"

#include <cmath>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace riskplan::geo {
namespace {

using ::testing::HasSubstr;

TEST(TargetGridTest, CentreAndSizeGiveWholeCellsAroundTheCentre) {
  AreaSpec area;
  area.center = LatLon{49.6116, 6.1319};
  area.width_m = 8000.0;
  area.height_m = 6000.0;
  area.res_m = 5.0;
  auto grid = MakeTargetGrid(area);
  ASSERT_TRUE(grid.ok()) << grid.status();
  EXPECT_EQ(grid->nx, 1600);
  EXPECT_EQ(grid->ny, 1200);
  EXPECT_EQ(grid->frame.x0(), 0.0);
  EXPECT_EQ(grid->frame.y0(), 0.0);
  // The centre lands at the middle of the map (to the millimetre: the frame
  // is centred at the corner, not at the centre).
  auto c = grid->frame.ToLocal(LatLon{49.6116, 6.1319});
  ASSERT_TRUE(c.ok()) << c.status();
  EXPECT_NEAR(c->x, 4000.0, 0.01);
  EXPECT_NEAR(c->y, 3000.0, 0.01);
  // The south-west corner is south-west of the centre by about 4 km and 3 km.
  EXPECT_NEAR(grid->frame.origin_lat_deg(), 49.6116 - 3000.0 / 111'150.0, 2e-4);
  EXPECT_LT(grid->frame.origin_lon_deg(), 6.1319 - 0.05);
}

TEST(TargetGridTest, BoundingBoxIsCoveredAndTight) {
  for (const LonLatBox box : {LonLatBox{6.05, 49.55, 6.20, 49.65},           // northern hemisphere
                              LonLatBox{-43.30, -22.95, -43.15, -22.85}}) {  // Rio de Janeiro
    AreaSpec area;
    area.bbox = box;
    area.res_m = 10.0;
    auto grid = MakeTargetGrid(area);
    ASSERT_TRUE(grid.ok()) << grid.status();
    double max_x = 0, max_y = 0;
    for (int k = 0; k <= 100; ++k) {
      const double t = k / 100.0;
      const double lon = box.west_lon_deg + t * (box.east_lon_deg - box.west_lon_deg);
      const double lat = box.south_lat_deg + t * (box.north_lat_deg - box.south_lat_deg);
      for (const LatLon p : {LatLon{box.south_lat_deg, lon}, LatLon{box.north_lat_deg, lon},
                             LatLon{lat, box.west_lon_deg}, LatLon{lat, box.east_lon_deg}}) {
        auto xy = grid->frame.ToLocal(p);
        ASSERT_TRUE(xy.ok()) << xy.status();
        // Inside the map, to the millimetre.
        EXPECT_GE(xy->x, -1e-3);
        EXPECT_GE(xy->y, -1e-3);
        EXPECT_LE(xy->x, grid->width_m() + 1e-3);
        EXPECT_LE(xy->y, grid->height_m() + 1e-3);
        max_x = std::max(max_x, xy->x);
        max_y = std::max(max_y, xy->y);
      }
    }
    // No more than a cell to spare.
    EXPECT_GT(max_x, grid->width_m() - grid->res_m);
    EXPECT_GT(max_y, grid->height_m() - grid->res_m);
  }
}

TEST(TargetGridTest, RefusesBadAreasNamingWhatIsWrong) {
  AreaSpec area;
  area.center = LatLon{49.6, 6.1};
  area.width_m = area.height_m = 400'000.0;
  area.res_m = 5.0;
  auto g = MakeTargetGrid(area);
  ASSERT_EQ(g.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(g.status().message(), HasSubstr("80000 cells"));

  area.width_m = area.height_m = 200'000.0;  // 40000 x 40000 cells: sides fine, too many cells
  g = MakeTargetGrid(area);
  ASSERT_EQ(g.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(g.status().message(), HasSubstr("map-bundle limit"));

  area.width_m = area.height_m = 8000.0;
  area.res_m = 0.0;
  EXPECT_THAT(MakeTargetGrid(area).status().message(), HasSubstr("cell size"));

  area.res_m = 5.0;
  area.center = LatLon{89.0, 0.0};
  EXPECT_THAT(MakeTargetGrid(area).status().message(), HasSubstr("latitude 89"));

  AreaSpec box;
  box.bbox = LonLatBox{6.2, 49.5, 6.1, 49.6};  // west east of east
  EXPECT_THAT(MakeTargetGrid(box).status().message(), HasSubstr("antimeridian"));
  box.bbox = LonLatBox{49.5, 6.1, 49.6, 6.2};  // lat/lon swapped: still a valid box, far away
  EXPECT_TRUE(MakeTargetGrid(box).ok());
  box.bbox = LonLatBox{6.1, 49.6, 6.2, 49.5};
  EXPECT_THAT(MakeTargetGrid(box).status().message(), HasSubstr("south"));
  box.center = LatLon{49.6, 6.1};
  EXPECT_THAT(MakeTargetGrid(box).status().message(), HasSubstr("not both"));
}

}  // namespace
}  // namespace riskplan::geo
