#include "client/picture/picture_draw.h"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "absl/strings/str_format.h"
#include "client/picture/bitmap_font.h"

namespace riskplan::client {

Rgb ScaleColour(double t) {
  static const Rgb kStops[] = {{250, 246, 214}, {255, 214, 110}, {240, 120, 40}, {120, 0, 30}};
  const double pos = std::clamp(t, 0.0, 1.0) * 3.0;
  const int i = std::min(2, static_cast<int>(pos));
  const double f = pos - i;
  return {kStops[i].r + (kStops[i + 1].r - kStops[i].r) * f,
          kStops[i].g + (kStops[i + 1].g - kStops[i].g) * f,
          kStops[i].b + (kStops[i + 1].b - kStops[i].b) * f};
}

// Logarithmic because densities span orders of magnitude (a park, a suburb,
// a centre): on a linear scale only the densest blocks would show.
Rgb DensityColour(float density, double high) {
  // Compared as a float, as the layer's values are.
  if (!(density > static_cast<float>(kDensityScaleLow))) return kNoPeopleColour;
  return ScaleColour(std::log10(density / kDensityScaleLow) / std::log10(high / kDensityScaleLow));
}

Rgb NoFlyTint(Rgb c) {
  return {c.r + (110 - c.r) * 0.65, c.g + (40 - c.g) * 0.65, c.b + (190 - c.b) * 0.65};
}

Rgb ImprovementColour(size_t k, size_t n) {
  const double t = n <= 1 ? 1.0 : static_cast<double>(k) / (n - 1);
  return {150 - 150 * t, 190 - 150 * t, 255 - 55 * t};
}

void Stamp(RgbaImage* img, double x, double y, double width, Rgb c, double alpha) {
  assert(img->pixels.size() == static_cast<size_t>(img->width) * img->height * 4);
  const int half = std::max(0, static_cast<int>(width / 2));
  const int cx = static_cast<int>(std::lround(x)), cy = static_cast<int>(std::lround(y));
  for (int py = cy - half; py <= cy + half; ++py) {
    for (int px = cx - half; px <= cx + half; ++px) {
      if (px < 0 || py < 0 || px >= img->width || py >= img->height) continue;
      uint8_t* p = &img->pixels[(static_cast<size_t>(py) * img->width + px) * 4];
      p[0] = static_cast<uint8_t>(p[0] + (c.r - p[0]) * alpha);
      p[1] = static_cast<uint8_t>(p[1] + (c.g - p[1]) * alpha);
      p[2] = static_cast<uint8_t>(p[2] + (c.b - p[2]) * alpha);
    }
  }
}

// One brush per pixel along the longer axis: dense enough for a gap-free
// line, and simple, since the picture needs no anti-aliasing.
void DrawLine(RgbaImage* img, double x0, double y0, double x1, double y1, double width, Rgb c,
              double alpha) {
  const double steps = std::max({std::fabs(x1 - x0), std::fabs(y1 - y0), 1.0});
  // A line this long reaches far off the picture (a pose in another frame,
  // say); drawing it would take a stamp per pixel of its length.
  if (steps > 1e5) return;
  for (int s = 0; s <= static_cast<int>(steps); ++s) {
    const double t = s / steps;
    Stamp(img, x0 + (x1 - x0) * t, y0 + (y1 - y0) * t, width, c, alpha);
  }
}

void DrawDisc(RgbaImage* img, double x, double y, double radius, Rgb c) {
  for (double dy = -radius; dy <= radius; dy += 1) {
    for (double dx = -radius; dx <= radius; dx += 1) {
      if (dx * dx + dy * dy <= radius * radius) Stamp(img, x + dx, y + dy, 1, c, 1.0);
    }
  }
}

void FillBox(RgbaImage* img, const PixelBox& box, Rgb c) {
  for (int y = box.y; y < box.y + box.height; ++y) {
    for (int x = box.x; x < box.x + box.width; ++x) Stamp(img, x, y, 1, c, 1.0);
  }
}

void DrawText(RgbaImage* img, const PlacedText& text, int scale, Rgb c) {
  ForEachTextPixel(text.text, scale,
                   [&](int x, int y) { Stamp(img, text.x + x, text.y + y, 1, c, 1.0); });
}

std::string SvgColour(Rgb c) {
  return absl::StrFormat("rgb(%d,%d,%d)", static_cast<int>(c.r), static_cast<int>(c.g),
                         static_cast<int>(c.b));
}

Rgb FleetColour(size_t k) {
  static constexpr Rgb kColours[] = {
      {30, 80, 220}, {230, 120, 0}, {0, 150, 150}, {150, 60, 200}, {120, 120, 120}, {0, 0, 0}};
  return kColours[k % (sizeof(kColours) / sizeof(kColours[0]))];
}

}  // namespace riskplan::client
