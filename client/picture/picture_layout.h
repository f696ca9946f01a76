// Where each part of a plan's picture lies (client/picture/picture.h): the caption
// on top, the map under it at one pixel per layer cell, and under the map
// the legend: the population-density colour scale with its decades, a key to
// what is drawn on the map, and a scale bar. Pure geometry, in pixels with
// (0, 0) at the top left and y growing down; the PNG and the SVG are both
// drawn from it.
#ifndef RISKPLAN_CLIENT_PICTURE_PICTURE_LAYOUT_H_
#define RISKPLAN_CLIENT_PICTURE_PICTURE_LAYOUT_H_

#include <string>
#include <vector>

#include "riskplan/v1/planner.pb.h"

namespace riskplan::client {

struct PictureInput;

// The density colour scale runs logarithmically from kDensityScaleLow people
// per m² (and anything below it is "no people") to DensityScaleHigh.
inline constexpr double kDensityScaleLow = 1e-5;
// The densest value of `layer`, but at least 1e-4, so that the scale spans a
// decade even on an empty map (no division by log 1 = 0).
double DensityScaleHigh(const v1::GetMapLayerResponse& layer);

struct PixelBox {
  int x = 0;
  int y = 0;
  int width = 0;
  int height = 0;
};

// A line of text; (x, y) is the top-left corner of its first glyph, whose
// capitals are 7 x text_scale pixels high, and descenders one more
// (client/picture/bitmap_font.h).
struct PlacedText {
  int x = 0;
  int y = 0;
  std::string text;
};

// What a key of the legend shows, drawn as on the map.
enum class LegendItem {
  kNoPeople,     // a box of the colour of land below kDensityScaleLow
  kNoFly,        // a box of the no-fly tint over such land
  kLandingSite,  // a landing site's marker
  kTree,         // a line of the planner's tree (only when the picture has one)
  kImprovement,  // a line of the first improvement's colour (only with two or more)
  kFinal,        // the final trajectory's bold line (only with one at least)
  kStart,        // the start's marker
  kGoal,         // the goal's marker
};

struct LegendKey {
  LegendItem item;
  PixelBox sample;  // the item's sample is drawn centred in it
  PlacedText label;
};

// A decade on the density scale; `label` is empty where it would overlap the
// previous one.
struct DensityTick {
  double density = 0;  // people per m²
  int x = 0;           // the tick's column
  PlacedText label;
};

struct PictureLayout {
  int width = 0;  // the whole picture
  int height = 0;
  int text_scale = 1;  // glyph pixels are text_scale x text_scale
  int line_height = 10;
  std::vector<PlacedText> caption;  // the caption, word-wrapped
  PixelBox map;                     // one pixel per layer cell, north up
  double metres_per_pixel = 1;      // the layer's cell side

  PlacedText density_title;
  PixelBox density_bar;  // kDensityScaleLow at its left edge, density_high at its right
  double density_high = 1e-4;
  std::vector<DensityTick> density_ticks;
  int tick_length = 2;  // ticks run down from the bar's bottom edge

  std::vector<LegendKey> keys;

  PixelBox scale_bar;      // solid; width == round(scale_bar_m / metres_per_pixel)
  double scale_bar_m = 0;  // a round number: 1, 2 or 5 times a power of ten metres
  PlacedText scale_label;  // "500 m", "2 km"
};

// The layout of `input`'s picture. The picture is at least wide enough for
// the legend, whatever the map's size.
// REQUIRES: input.density holds nx * ny values (WritePicture checks it).
PictureLayout LayoutPicture(const PictureInput& input);

// The longest of 1, 2 and 5 times a power of ten metres that is at most
// `max_pixels` long at `metres_per_pixel`.
// REQUIRES: metres_per_pixel > 0, max_pixels >= 1.
double ScaleBarMetres(double metres_per_pixel, int max_pixels);

// "500 m", "2 km", "0.5 m".
std::string ScaleBarLabel(double metres);

}  // namespace riskplan::client

#endif  // RISKPLAN_CLIENT_PICTURE_PICTURE_LAYOUT_H_
