#include "client/picture/picture.h"

#include <cmath>
#include <string>

#include "client/picture/bitmap_font.h"
#include "client/picture/picture_draw.h"
#include "client/picture/picture_layout.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace riskplan::client {
namespace {

using ::testing::HasSubstr;

struct Pixel {
  int r, g, b;
  bool operator==(const Pixel&) const = default;
};

std::ostream& operator<<(std::ostream& os, const Pixel& p) {
  return os << "rgb(" << p.r << "," << p.g << "," << p.b << ")";
}

Pixel At(const RgbaImage& img, int x, int y) {
  const uint8_t* p = &img.pixels[(static_cast<size_t>(y) * img.width + x) * 4];
  return {p[0], p[1], p[2]};
}

// How many pixels of `box` have colour `c`.
int CountIn(const RgbaImage& img, const PixelBox& box, Pixel c) {
  int n = 0;
  for (int y = box.y; y < box.y + box.height; ++y) {
    for (int x = box.x; x < box.x + box.width; ++x) n += At(img, x, y) == c;
  }
  return n;
}

// The picture's colours, as the map draws them (client/picture/picture_draw.h).
constexpr Pixel kNoPeople = {236, 240, 230};
constexpr Pixel kNoFlyOverNoPeople = {154, 110, 204};  // 65 % of (110, 40, 190) over kNoPeople
constexpr Pixel kLandingSite = {20, 150, 60};
constexpr Pixel kFirstImprovement = {181, 209, 255};  // (150, 190, 255) at 70 % over white
constexpr Pixel kFinal = {0, 40, 200};
constexpr Pixel kStart = {0, 170, 70};
constexpr Pixel kGoal = {200, 0, 160};
constexpr Pixel kText = {40, 40, 40};
constexpr Pixel kBlack = {0, 0, 0};

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

// A map of nx x ny empty cells of `cell_m` metres, a straight final
// trajectory along its diagonal from 10 % to 90 %, and one landing site.
PictureInput EmptyMap(int nx, int ny, double cell_m) {
  PictureInput in;
  in.density.set_nx(nx);
  in.density.set_ny(ny);
  in.density.set_cell_m(cell_m);
  for (int i = 0; i < nx * ny; ++i) in.density.add_values(0.0f);
  v1::Trajectory t;
  for (double f : {0.1, 0.9}) {
    v1::Pose* p = t.add_path();
    p->set_x(f * nx * cell_m);
    p->set_y(f * ny * cell_m);
  }
  in.improvements = {t};
  in.start = t.path(0);
  in.goal = t.path(1);
  v1::LandingSite* site = in.map.add_landing_sites();
  site->set_x(0.5 * nx * cell_m);
  site->set_y(0.25 * ny * cell_m);
  in.caption = "demo-city, RISK_RRT_STAR: 1 improvements";
  return in;
}

const LegendKey* FindKey(const PictureLayout& layout, LegendItem item) {
  for (const LegendKey& key : layout.keys) {
    if (key.item == item) return &key;
  }
  return nullptr;
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

TEST(PictureLegendTest, DensityScaleRunsFromPaleToDarkRedWithItsDecades) {
  const PictureInput in = TwoByTwo();  // densest cell 0.1 people per m²
  const PictureLayout layout = LayoutPicture(in);
  const RgbaImage img = RenderPicture(in);
  ASSERT_EQ(img.width, layout.width);
  ASSERT_EQ(img.height, layout.height);
  const PixelBox& bar = layout.density_bar;
  EXPECT_EQ(layout.density_high, 0.1f);
  EXPECT_EQ(At(img, bar.x, bar.y), (Pixel{250, 246, 214}));
  EXPECT_EQ(At(img, bar.x + bar.width - 1, bar.y + bar.height - 1), (Pixel{120, 0, 30}));
  EXPECT_EQ(layout.density_title.text, "population density, people/m²");
  EXPECT_GT(CountIn(img, {layout.density_title.x, layout.density_title.y, 100, 7}, kText), 50);
  // A tick and a label at every decade from 1e-5 to 0.1, the ends at the
  // bar's ends.
  ASSERT_EQ(layout.density_ticks.size(), 5u);
  EXPECT_EQ(layout.density_ticks.front().x, bar.x);
  EXPECT_EQ(layout.density_ticks.back().x, bar.x + bar.width - 1);
  for (const DensityTick& tick : layout.density_ticks) {
    EXPECT_EQ(At(img, tick.x, bar.y + bar.height), kText);
    EXPECT_GT(CountIn(img, {tick.label.x, tick.label.y, TextWidth(tick.label.text, 1), 7}, kText),
              5)
        << tick.label.text;
  }
  EXPECT_EQ(layout.density_ticks[0].label.text, "1e-5");
  EXPECT_EQ(layout.density_ticks[4].label.text, "1e-1");
}

TEST(PictureLegendTest, EveryKeyShowsTheMapsColourAndItsLabel) {
  PictureInput in = TwoByTwo();  // two improvements, no tree
  v1::LandingSite* site = in.map.add_landing_sites();
  site->set_x(100);
  site->set_y(100);
  const PictureLayout layout = LayoutPicture(in);
  const RgbaImage img = RenderPicture(in);
  const struct {
    LegendItem item;
    Pixel centre;
    const char* label;
  } kKeys[] = {
      {LegendItem::kNoPeople, kNoPeople, "no people"},
      {LegendItem::kNoFly, kNoFlyOverNoPeople, "no-fly"},
      {LegendItem::kLandingSite, kLandingSite, "landing site"},
      {LegendItem::kImprovement, kFirstImprovement, "earlier improvements"},
      {LegendItem::kFinal, kFinal, "final trajectory"},
      {LegendItem::kStart, kStart, "start"},
      {LegendItem::kGoal, kGoal, "goal"},
  };
  for (const auto& expected : kKeys) {
    const LegendKey* key = FindKey(layout, expected.item);
    ASSERT_NE(key, nullptr) << expected.label;
    const PixelBox& b = key->sample;
    EXPECT_EQ(At(img, b.x + (b.width - 1) / 2, b.y + (b.height - 1) / 2), expected.centre)
        << expected.label;
    EXPECT_EQ(key->label.text, expected.label);
    EXPECT_GT(CountIn(img, {key->label.x, key->label.y, TextWidth(key->label.text, 1), 7}, kText),
              5)
        << expected.label;
    // Inside the picture, under the map.
    EXPECT_GE(b.y, layout.map.y + layout.map.height);
    EXPECT_LE(key->label.x + TextWidth(key->label.text, 1), layout.width);
    EXPECT_LE(b.y + b.height, layout.height);
  }
  // No tree in the picture, so no key for it.
  EXPECT_EQ(FindKey(layout, LegendItem::kTree), nullptr);
  in.tree.emplace_back();
  EXPECT_NE(FindKey(LayoutPicture(in), LegendItem::kTree), nullptr);
}

TEST(PictureLegendTest, EveryCharacterOfTheLegendHasAGlyph) {
  const PictureLayout layout = LayoutPicture(TwoByTwo());
  std::vector<std::string> texts = {layout.density_title.text, layout.scale_label.text};
  for (const LegendKey& key : layout.keys) texts.push_back(key.label.text);
  for (const DensityTick& tick : layout.density_ticks) texts.push_back(tick.label.text);
  for (const std::string& text : texts) {
    for (size_t i = 0; i < text.size(); ++i) {
      if (text.compare(i, 2, "²") == 0) {
        EXPECT_TRUE(HasGlyph(U'²'));
        ++i;
        continue;
      }
      EXPECT_TRUE(HasGlyph(static_cast<unsigned char>(text[i]))) << text << " at " << i;
    }
  }
}

TEST(PictureLegendTest, ScaleBarIsItsLabelledLengthInMetresAtTheMapsScale) {
  // 5 m cells: 500 m is 100 pixels; 7.5 m cells: 1 km is 133.3 pixels.
  for (const auto& [nx, cell_m, label] :
       {std::tuple{400, 5.0, "500 m"}, std::tuple{800, 7.5, "1 km"}, std::tuple{2, 100.0, "2 km"},
        std::tuple{1600, 0.5, "200 m"}}) {
    const PictureInput in = EmptyMap(nx, 50, cell_m);
    const PictureLayout layout = LayoutPicture(in);
    const RgbaImage img = RenderPicture(in);
    EXPECT_EQ(layout.scale_label.text, label);
    // The label's number and unit, read back.
    const double number = std::stod(layout.scale_label.text);
    const bool km = layout.scale_label.text.ends_with(" km");
    const double metres = number * (km ? 1000 : 1);
    EXPECT_EQ(metres, layout.scale_bar_m);
    // The bar: a run of black pixels along its middle row, exactly its
    // labelled metres at the map's metres per pixel (rounded to a pixel).
    const int row = layout.scale_bar.y + layout.scale_bar.height / 2;
    int run = 0;
    while (At(img, layout.scale_bar.x + run, row) == kBlack) ++run;
    EXPECT_EQ(run, std::lround(metres / cell_m)) << label;
    EXPECT_EQ(At(img, layout.scale_bar.x - 1, row), (Pixel{255, 255, 255}));
    EXPECT_GT(
        CountIn(img,
                {layout.scale_label.x, layout.scale_label.y,
                 TextWidth(layout.scale_label.text, layout.text_scale), 7 * layout.text_scale},
                kText),
        10);
  }
}

TEST(PictureLegendTest, ScaleBarLengthsAreRoundNumbers) {
  EXPECT_EQ(ScaleBarMetres(10, 200), 2000);
  EXPECT_EQ(ScaleBarMetres(5, 100), 500);
  EXPECT_EQ(ScaleBarMetres(5, 99), 200);
  EXPECT_EQ(ScaleBarMetres(1, 99), 50);
  EXPECT_EQ(ScaleBarMetres(0.5, 100), 50);
  EXPECT_EQ(ScaleBarLabel(2000), "2 km");
  EXPECT_EQ(ScaleBarLabel(500), "500 m");
  EXPECT_EQ(ScaleBarLabel(0.5), "0.5 m");
}

TEST(PictureTest, PictureHoldsTheMapWithItsTrajectoryAndMarkers) {
  const PictureInput in = EmptyMap(100, 100, 10);  // 1 km square
  const PictureLayout layout = LayoutPicture(in);
  const RgbaImage img = RenderPicture(in);
  ASSERT_EQ(layout.map.width, 100);
  ASSERT_EQ(layout.map.height, 100);
  // The caption above the map, the legend under it.
  ASSERT_EQ(layout.caption.size(), 1u);
  EXPECT_LT(layout.caption[0].y + 7, layout.map.y);
  // The final trajectory runs along the diagonal, (100, 100) m to
  // (900, 900) m: map pixels (10, 90) to (90, 10), north up.
  for (int k = 20; k <= 80; k += 10) {
    EXPECT_EQ(At(img, layout.map.x + k, layout.map.y + 100 - k), kFinal) << k;
  }
  EXPECT_EQ(At(img, layout.map.x + 10, layout.map.y + 90), kStart);
  EXPECT_EQ(At(img, layout.map.x + 90, layout.map.y + 10), kGoal);
  EXPECT_EQ(At(img, layout.map.x + 50, layout.map.y + 75), kLandingSite);
  EXPECT_EQ(At(img, layout.map.x + 30, layout.map.y + 20), kNoPeople);
}

TEST(PictureTest, TrajectoryLeavingTheMapIsCutAtItsEdge) {
  PictureInput in = EmptyMap(100, 100, 10);
  v1::Pose* far = in.improvements[0].add_path();
  far->set_x(500);
  far->set_y(-3000);  // 300 pixels under the map, across the legend
  const PictureLayout layout = LayoutPicture(in);
  const RgbaImage img = RenderPicture(in);
  const LegendKey* final_key = FindKey(layout, LegendItem::kFinal);
  ASSERT_NE(final_key, nullptr);
  const int on_map = CountIn(img, layout.map, kFinal);
  const int on_key = CountIn(img, final_key->sample, kFinal);
  EXPECT_GT(on_map, 100);
  EXPECT_GT(on_key, 0);
  EXPECT_EQ(CountIn(img, {0, 0, img.width, img.height}, kFinal), on_map + on_key);
}

TEST(PictureTest, SvgHasTheLegendAndTheScaleBar) {
  const std::string svg = RenderSvg(EmptyMap(400, 50, 5));
  EXPECT_THAT(svg, HasSubstr("<linearGradient id=\"density-scale\">"));
  EXPECT_THAT(svg, HasSubstr(">population density, people/m²</text>"));
  EXPECT_THAT(svg, HasSubstr(">no-fly</text>"));
  EXPECT_THAT(svg, HasSubstr(">landing site</text>"));
  EXPECT_THAT(svg, HasSubstr(">final trajectory</text>"));
  EXPECT_THAT(svg, HasSubstr(">500 m</text>"));
  EXPECT_THAT(svg, HasSubstr("width=\"100\" height=\"4\" fill=\"rgb(0,0,0)\""));  // the bar
  EXPECT_THAT(svg, HasSubstr("clip-path=\"url(#map)\""));
}

TEST(PictureTest, TheWindIsAnArrowDownwindWithItsSpeedOnlyWhenThereIsWind) {
  PictureInput in = EmptyMap(200, 200, 10);  // 2 km square
  in.improvements.clear();  // nothing else crosses the arrow's corner
  EXPECT_THAT(RenderSvg(in), ::testing::Not(::testing::HasSubstr("class=\"wind\"")));
  const RgbaImage calm = RenderPicture(in);
  // A west wind of 8 m/s: the air moves east, the arrow points right.
  in.wind.set_speed_mps(8);
  in.wind.set_from_deg(270);
  in.wind.set_x_mps(8);
  in.wind.set_y_mps(0);
  const std::string svg = RenderSvg(in);
  EXPECT_THAT(svg, ::testing::HasSubstr("<title>wind 8 m/s, from 270 deg (grid north)</title>"));
  EXPECT_THAT(svg, ::testing::HasSubstr(">wind 8 m/s</text>"));
  // The shaft runs from left to right at one height, its head on the right.
  EXPECT_THAT(svg, ::testing::HasSubstr("<line x1=\"140.0\" y1=\"34.0\" x2=\"170.0\" "
                                        "y2=\"34.0\""));
  const PictureLayout layout = LayoutPicture(in);
  const RgbaImage windy = RenderPicture(in);
  // The PNG's shaft: dark pixels along y = 34 of the map where the calm
  // picture had none.
  int dark = 0;
  for (int x = 142; x <= 170; ++x) {
    const Pixel c = At(windy, layout.map.x + x, layout.map.y + 34);
    dark += c.r < 60 && c.g < 60 && c.b < 60;
    EXPECT_FALSE(At(calm, layout.map.x + x, layout.map.y + 34).r < 60) << x;
  }
  EXPECT_GT(dark, 20);
}

TEST(PictureTest, AFleetKeyGivesEachRouteItsColourAndLabel) {
  PictureInput in = EmptyMap(200, 200, 10);
  in.improvements.clear();
  for (double y : {500.0, 1500.0}) {
    v1::Trajectory t;
    for (double x : {100.0, 1900.0}) {
      v1::Pose* p = t.add_path();
      p->set_x(x);
      p->set_y(y);
    }
    in.fleet.push_back(t);
  }
  in.fleet_labels = {"still-air", "wind"};
  in.fleet_key = true;
  const std::string svg = RenderSvg(in);
  EXPECT_THAT(svg, ::testing::HasSubstr(">still-air</text>"));
  EXPECT_THAT(svg, ::testing::HasSubstr(">wind</text>"));
  EXPECT_THAT(svg, ::testing::HasSubstr(SvgColour(FleetColour(0))));
  EXPECT_THAT(svg, ::testing::HasSubstr(SvgColour(FleetColour(1))));
  EXPECT_NE(SvgColour(FleetColour(0)), SvgColour(FleetColour(1)));
}

}  // namespace
}  // namespace riskplan::client
