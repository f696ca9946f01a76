#include "client/picture/picture_layout.h"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "client/picture/bitmap_font.h"
#include "client/picture/picture.h"
#include "client/picture/picture_draw.h"

namespace riskplan::client {
namespace {

// The legend's text needs about this much room (the density scale and its
// title, two keys to a row); a smaller map gets a wider picture.
constexpr int kMinWidth = 280;
// A map this wide gets glyphs twice the size, so that labels keep their size
// relative to the map.
constexpr int kDoubleTextWidth = 1200;
constexpr int kDensityBarWidth = 240;
// A key's sample is as high as the largest marker on the map (the start's and
// goal's discs), and a little wider for the lines.
constexpr int kMarkerSide = 2 * static_cast<int>(kEndpointRadius) + 1;
constexpr int kSampleWidth = kMarkerSide + 3;

// Greedy word wrap of `text` into lines of at most `width` pixels.
std::vector<std::string> WrapText(const std::string& text, int width, int scale) {
  std::vector<std::string> lines;
  std::string line;
  for (absl::string_view word : absl::StrSplit(text, ' ', absl::SkipEmpty())) {
    std::string longer = line.empty() ? std::string(word) : line + " " + std::string(word);
    if (!line.empty() && TextWidth(longer, scale) > width) {
      lines.push_back(line);
      longer = std::string(word);
    }
    line = longer;
  }
  if (!line.empty()) lines.push_back(line);
  return lines;
}

// 1e-5, 1e-4, ... 0.1 as "1e-N"; 1, 10, 100 as themselves.
std::string DecadeLabel(int exponent) {
  if (exponent < 0) return absl::StrFormat("1e%d", exponent);
  return absl::StrFormat("%.0f", std::pow(10.0, exponent));
}

const char* LegendLabel(LegendItem item) {
  switch (item) {
    case LegendItem::kNoPeople:
      return "no people";
    case LegendItem::kNoFly:
      return "no-fly";
    case LegendItem::kLandingSite:
      return "landing site";
    case LegendItem::kTree:
      return "tree";
    case LegendItem::kImprovement:
      return "earlier improvements";
    case LegendItem::kFinal:
      return "final trajectory";
    case LegendItem::kStart:
      return "start";
    case LegendItem::kGoal:
      return "goal";
  }
  return "";
}

}  // namespace

double DensityScaleHigh(const v1::GetMapLayerResponse& layer) {
  float max_density = 0.0f;
  for (float d : layer.values()) max_density = std::max(max_density, d);
  return std::max(1e-4, static_cast<double>(max_density));
}

double ScaleBarMetres(double metres_per_pixel, int max_pixels) {
  assert(metres_per_pixel > 0 && max_pixels >= 1);
  const double longest = metres_per_pixel * max_pixels;
  const double power = std::pow(10.0, std::floor(std::log10(longest)));
  for (double factor : {5.0, 2.0, 1.0}) {
    // The tolerance keeps 2000 m from becoming 1000 m when 2000 m is
    // exactly the longest and log10 rounds down.
    if (factor * power <= longest * (1 + 1e-9)) return factor * power;
  }
  return power / 2;  // not reached: power <= longest
}

std::string ScaleBarLabel(double metres) {
  if (metres >= 1000) return absl::StrFormat("%g km", metres / 1000);
  return absl::StrFormat("%g m", metres);
}

PictureLayout LayoutPicture(const PictureInput& in) {
  PictureLayout l;
  const int map_width = std::max(0, in.density.nx());
  const int map_height = std::max(0, in.density.ny());
  const int s = map_width >= kDoubleTextWidth ? 2 : 1;
  l.text_scale = s;
  l.line_height = (kCapHeight + 3) * s;
  const int pad = 6 * s;
  l.width = std::max(map_width, kMinWidth * s);
  const int text_width = l.width - 2 * pad;
  // A zero cell size (a malformed response) is taken as 1 m, as the
  // picture's projection does.
  l.metres_per_pixel = in.density.cell_m() > 0 ? in.density.cell_m() : 1;

  int y = 0;
  if (!in.caption.empty()) {
    y = pad;
    for (std::string& line : WrapText(in.caption, text_width, s)) {
      l.caption.push_back({pad, y, std::move(line)});
      y += l.line_height;
    }
  }
  l.map = {0, y, map_width, map_height};
  y += map_height + pad;

  // The density scale: title, bar, ticks at the decades with their labels.
  l.density_title = {pad, y, "population density, people/m²"};
  y += l.line_height;
  l.density_high = DensityScaleHigh(in.density);
  l.density_bar = {pad, y, std::min(kDensityBarWidth * s, text_width), 8 * s};
  l.tick_length = 2 * s;
  y += l.density_bar.height + l.tick_length + s;
  const double decades = std::log10(l.density_high / kDensityScaleLow);
  int labels_end = 0;  // right edge of the last label placed
  for (int k = -5; std::pow(10.0, k) <= l.density_high * (1 + 1e-9); ++k) {
    DensityTick tick;
    tick.density = std::pow(10.0, k);
    const double t = std::log10(tick.density / kDensityScaleLow) / decades;
    tick.x = l.density_bar.x + std::min(l.density_bar.width - 1,
                                        static_cast<int>(std::lround(t * l.density_bar.width)));
    const std::string label = DecadeLabel(k);
    const int w = TextWidth(label, s);
    const int x = std::clamp(tick.x - w / 2, pad, l.width - pad - w);
    if (labels_end == 0 || x >= labels_end + 3 * s) {
      tick.label = {x, y, label};
      labels_end = x + w;
    }
    l.density_ticks.push_back(tick);
  }
  y += l.line_height + s;

  // The keys, flowed into rows.
  std::vector<LegendItem> items = {LegendItem::kNoPeople, LegendItem::kNoFly,
                                   LegendItem::kLandingSite};
  if (!in.tree.empty()) items.push_back(LegendItem::kTree);
  if (in.improvements.size() >= 2) items.push_back(LegendItem::kImprovement);
  if (!in.improvements.empty()) items.push_back(LegendItem::kFinal);
  items.push_back(LegendItem::kStart);
  items.push_back(LegendItem::kGoal);
  const int row_height = std::max(kMarkerSide, l.line_height);
  int x = pad;
  for (LegendItem item : items) {
    const std::string label = LegendLabel(item);
    const int width = kSampleWidth + 4 * s + TextWidth(label, s);
    if (x > pad && x + width > l.width - pad) {
      x = pad;
      y += row_height;
    }
    LegendKey key{item, {x, y + (row_height - kMarkerSide) / 2, kSampleWidth, kMarkerSide}, {}};
    key.label = {x + kSampleWidth + 4 * s, y + (row_height - kCapHeight * s) / 2, label};
    l.keys.push_back(std::move(key));
    x += width + 10 * s;
  }
  y += row_height + pad;

  // The scale bar: about a quarter of the map's width, with room for its
  // label beside it.
  const int label_room = TextWidth("500 km", s) + 2 * pad;
  const int max_bar =
      std::max(1, std::min(std::max(map_width / 4, 40 * s), text_width - label_room));
  l.scale_bar_m = ScaleBarMetres(l.metres_per_pixel, max_bar);
  const int bar_height = 4 * s;
  l.scale_bar = {pad, y + (l.line_height - bar_height) / 2 - s,
                 static_cast<int>(std::lround(l.scale_bar_m / l.metres_per_pixel)), bar_height};
  l.scale_label = {l.scale_bar.x + l.scale_bar.width + pad, y, ScaleBarLabel(l.scale_bar_m)};
  y += l.line_height + pad;
  l.height = y;
  return l;
}

}  // namespace riskplan::client
