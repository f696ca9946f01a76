// The colours of a plan's picture and the raster drawing it is made of,
// shared by the map (client/picture/picture.cc) and its legend
// (client/picture/picture_legend.cc), so that a key shows exactly what the map does.
#ifndef RISKPLAN_CLIENT_PICTURE_PICTURE_DRAW_H_
#define RISKPLAN_CLIENT_PICTURE_PICTURE_DRAW_H_

#include <cstddef>
#include <string>

#include "client/picture/picture.h"
#include "client/picture/picture_layout.h"

namespace riskplan::client {

struct Rgb {
  double r, g, b;
};

// Land with fewer than kDensityScaleLow people per m².
inline constexpr Rgb kNoPeopleColour = {236, 240, 230};
inline constexpr Rgb kLandingSiteColour = {20, 150, 60};
inline constexpr Rgb kTreeColour = {70, 70, 70};
inline constexpr double kTreeAlpha = 0.3;
inline constexpr double kImprovementAlpha = 0.7;  // every improvement but the final one
inline constexpr Rgb kStartColour = {0, 170, 70};
inline constexpr Rgb kGoalColour = {200, 0, 160};
inline constexpr Rgb kTextColour = {40, 40, 40};
inline constexpr Rgb kScaleBarColour = {0, 0, 0};
// Markers on the PNG map: landing sites, then start and goal.
inline constexpr double kLandingSiteRadius = 3;
inline constexpr double kEndpointRadius = 6;
// Line widths on the PNG map, pixels.
inline constexpr double kImprovementWidth = 1;
inline constexpr double kFinalWidth = 3;

// The density scale's colour at t in [0, 1], from its low end (pale yellow)
// to its high end (dark red).
Rgb ScaleColour(double t);

// The colour of a cell of `density` people per m² on a scale whose top is
// `high` (DensityScaleHigh): kNoPeopleColour below kDensityScaleLow, else
// ScaleColour of the density's place on a log scale.
Rgb DensityColour(float density, double high);

// A no-fly cell of colour `c`, tinted violet (a hue the density scale never
// uses).
Rgb NoFlyTint(Rgb c);

// Improvement `k` of `n`: from light blue (the first) to dark blue (the last,
// the final trajectory).
Rgb ImprovementColour(size_t k, size_t n);

// The wind arrow's colour, and fleet trajectory `k`'s when the picture has a
// fleet key (PictureInput::fleet_key): a few hues the density scale and the
// improvements do not use, repeating after the sixth.
inline constexpr Rgb kWindColour = {20, 20, 20};
Rgb FleetColour(size_t k);

// Blends a square brush of side `width` pixels centred on (x, y) with `c`
// at `alpha`. Pixels off the image are skipped. Alpha stays 255: what is
// drawn on is opaque.
void Stamp(RgbaImage* img, double x, double y, double width, Rgb c, double alpha);

// A line of brushes, one per pixel along its longer axis; a line longer than
// 1e5 pixels (a pose far off the picture) is not drawn.
void DrawLine(RgbaImage* img, double x0, double y0, double x1, double y1, double width, Rgb c,
              double alpha);

void DrawDisc(RgbaImage* img, double x, double y, double radius, Rgb c);

// Fills `box` with `c`, where it lies on the image.
void FillBox(RgbaImage* img, const PixelBox& box, Rgb c);

// `text` in the bitmap font at `scale`, in colour `c`.
void DrawText(RgbaImage* img, const PlacedText& text, int scale, Rgb c);

// "rgb(r,g,b)" for SVG.
std::string SvgColour(Rgb c);

}  // namespace riskplan::client

#endif  // RISKPLAN_CLIENT_PICTURE_PICTURE_DRAW_H_
