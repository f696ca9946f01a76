#include "client/picture.h"

#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace riskplan::client {
namespace {

using ::testing::HasSubstr;

PictureInput TwoByTwo() {
  PictureInput in;
  in.density.set_nx(2);
  in.density.set_ny(2);
  in.density.set_cell_m(100);
  for (float v : {0.0f, 0.01f, 0.001f, 0.1f}) in.density.add_values(v);
  in.nofly = in.density;
  in.nofly.clear_values();
  for (float v : {0.0f, 0.0f, 0.0f, 1.0f}) in.nofly.add_values(v);
  v1::Trajectory t;
  for (double x : {10.0, 190.0}) {
    v1::Pose* p = t.add_path();
    p->set_x(x);
    p->set_y(x);
  }
  t.set_risk(1e-7);
  in.improvements = {t, t};
  in.start.set_x(10);
  in.start.set_y(10);
  in.goal.set_x(190);
  in.goal.set_y(190);
  in.caption = "a < b";
  return in;
}

TEST(PictureTest, RasterIsNorthUpWithNoFlyTintedViolet) {
  RgbaImage img = RenderMapRaster(TwoByTwo());
  ASSERT_EQ(img.width, 2);
  ASSERT_EQ(img.height, 2);
  // Layer row 0 (south) is the image's bottom row. Cell (0, 0) is empty land.
  const uint8_t* south_west = &img.pixels[(1 * 2 + 0) * 4];
  EXPECT_EQ(south_west[0], 236);
  EXPECT_EQ(south_west[1], 240);
  // Cell (1, 1), north-east: no-fly, so violet (blue over green).
  const uint8_t* north_east = &img.pixels[(0 * 2 + 1) * 4];
  EXPECT_GT(north_east[2], 2 * north_east[1]);
  // Cell (1, 0), south-east: dense but flyable, so red-orange (red over blue).
  const uint8_t* south_east = &img.pixels[(1 * 2 + 1) * 4];
  EXPECT_GT(south_east[0], 2 * south_east[2]);
}

TEST(PictureTest, SvgHoldsRasterPathsAndEscapedCaption) {
  const std::string svg = RenderSvg(TwoByTwo());
  EXPECT_THAT(svg, HasSubstr("<svg xmlns=\"http://www.w3.org/2000/svg\""));
  EXPECT_THAT(svg, HasSubstr("data:image/png;base64,iVBORw0KGgo"));  // the PNG signature
  EXPECT_THAT(svg, HasSubstr("a &lt; b"));
  // Two improvements; the last one bold. Coordinates: x 10 m -> 0.1 px,
  // y 10 m -> 2 - 0.1 = 1.9 px.
  EXPECT_THAT(svg, HasSubstr("points=\"0.1,1.9 1.9,0.1 \""));
  EXPECT_THAT(svg, HasSubstr("stroke-width=\"3.0\""));
}

TEST(PictureTest, PngSignatureAndBadExtension) {
  absl::StatusOr<std::string> png = EncodePng(RenderMapRaster(TwoByTwo()));
  ASSERT_TRUE(png.ok());
  EXPECT_EQ(png->substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  EXPECT_EQ(WritePicture("/tmp/x.gif", TwoByTwo()).code(), absl::StatusCode::kInvalidArgument);
}

TEST(PictureTest, DensityLayerWithoutNxTimesNyValuesIsRefused) {
  PictureInput in = TwoByTwo();
  in.density.add_values(0.5f);  // 5 values for 2 x 2 cells
  const std::string path = ::testing::TempDir() + "picture_test_bad_layer.png";
  const absl::Status status = WritePicture(path, in);
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(status.message()),
              HasSubstr("the density layer has 5 values for 2 x 2 cells"));
}

}  // namespace
}  // namespace riskplan::client
