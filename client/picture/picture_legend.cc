#include "client/picture/picture_legend.h"

#include <cassert>

#include "absl/strings/str_format.h"
#include "client/picture/bitmap_font.h"
#include "client/picture/picture_draw.h"
#include "geo/export/xml_text.h"

namespace riskplan::client {
namespace {

// The keys' boxes have a border, so that the pale no-people colour shows on
// the white legend.
constexpr Rgb kBoxBorder = {150, 150, 150};

double CentreX(const PixelBox& b) { return b.x + (b.width - 1) / 2.0; }
double CentreY(const PixelBox& b) { return b.y + (b.height - 1) / 2.0; }

void DrawBoxKey(RgbaImage* img, const PixelBox& b, Rgb fill) {
  FillBox(img, b, kBoxBorder);
  FillBox(img, {b.x + 1, b.y + 1, b.width - 2, b.height - 2}, fill);
}

void DrawLineKey(RgbaImage* img, const PixelBox& b, double width, Rgb c, double alpha) {
  DrawLine(img, b.x + 1, CentreY(b), b.x + b.width - 2, CentreY(b), width, c, alpha);
}

// SVG text: the bitmap font's capitals are 7 pixels high from their top, so
// the baseline is 7 * scale below the layout's y, and a 9 * scale font has
// capitals about as high.
std::string SvgText(const PlacedText& t, int scale) {
  return absl::StrFormat(
      "<text x=\"%d\" y=\"%d\" font-family=\"sans-serif\" font-size=\"%d\" fill=\"%s\">%s</text>\n",
      t.x, t.y + kCapHeight * scale, 9 * scale, SvgColour(kTextColour), geo::XmlEscape(t.text));
}

std::string SvgBoxKey(const PixelBox& b, Rgb fill) {
  return absl::StrFormat(
      "<rect x=\"%.1f\" y=\"%.1f\" width=\"%d\" height=\"%d\" fill=\"%s\" stroke=\"%s\" "
      "stroke-width=\"1\"/>\n",
      b.x + 0.5, b.y + 0.5, b.width - 1, b.height - 1, SvgColour(fill), SvgColour(kBoxBorder));
}

std::string SvgLineKey(const PixelBox& b, double width, Rgb c, double opacity) {
  return absl::StrFormat(
      "<line x1=\"%d\" y1=\"%.1f\" x2=\"%d\" y2=\"%.1f\" stroke=\"%s\" stroke-width=\"%.1f\" "
      "stroke-opacity=\"%.2f\"/>\n",
      b.x + 1, CentreY(b) + 0.5, b.x + b.width - 1, CentreY(b) + 0.5, SvgColour(c), width, opacity);
}

// The marker of a start or goal, as the SVG map draws it.
std::string SvgEndpointKey(const PixelBox& b, Rgb c) {
  return absl::StrFormat(
      "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"6\" fill=\"%s\" stroke=\"white\" stroke-width=\"1\"/>\n",
      CentreX(b) + 0.5, CentreY(b) + 0.5, SvgColour(c));
}

}  // namespace

void DrawCaptionAndLegend(RgbaImage* img, const PictureLayout& l, size_t improvements) {
  assert(img->width == l.width && img->height == l.height);
  const int s = l.text_scale;
  for (const PlacedText& line : l.caption) DrawText(img, line, s, kTextColour);

  DrawText(img, l.density_title, s, kTextColour);
  const PixelBox& bar = l.density_bar;
  for (int i = 0; i < bar.width; ++i) {
    const Rgb c = ScaleColour(bar.width == 1 ? 1.0 : static_cast<double>(i) / (bar.width - 1));
    FillBox(img, {bar.x + i, bar.y, 1, bar.height}, c);
  }
  for (const DensityTick& tick : l.density_ticks) {
    FillBox(img, {tick.x, bar.y + bar.height, s, l.tick_length}, kTextColour);
    DrawText(img, tick.label, s, kTextColour);
  }

  for (const LegendKey& key : l.keys) {
    const PixelBox& b = key.sample;
    switch (key.item) {
      case LegendItem::kNoPeople:
        DrawBoxKey(img, b, kNoPeopleColour);
        break;
      case LegendItem::kNoFly:
        DrawBoxKey(img, b, NoFlyTint(kNoPeopleColour));
        break;
      case LegendItem::kLandingSite:
        DrawDisc(img, CentreX(b), CentreY(b), kLandingSiteRadius, kLandingSiteColour);
        break;
      case LegendItem::kTree:
        DrawLineKey(img, b, 1, kTreeColour, kTreeAlpha);
        break;
      case LegendItem::kImprovement:
        DrawLineKey(img, b, kImprovementWidth, ImprovementColour(0, improvements),
                    kImprovementAlpha);
        break;
      case LegendItem::kFinal:
        DrawLineKey(img, b, kFinalWidth, ImprovementColour(improvements - 1, improvements), 1.0);
        break;
      case LegendItem::kStart:
        DrawDisc(img, CentreX(b), CentreY(b), kEndpointRadius, kStartColour);
        break;
      case LegendItem::kGoal:
        DrawDisc(img, CentreX(b), CentreY(b), kEndpointRadius, kGoalColour);
        break;
    }
    DrawText(img, key.label, s, kTextColour);
  }

  FillBox(img, l.scale_bar, kScaleBarColour);
  DrawText(img, l.scale_label, s, kTextColour);
}

std::string SvgCaptionAndLegend(const PictureLayout& l, size_t improvements) {
  const int s = l.text_scale;
  std::string svg;
  for (const PlacedText& line : l.caption) svg += SvgText(line, s);

  // The density scale's four colour stops, evenly spaced as in ScaleColour.
  svg += "<defs><linearGradient id=\"density-scale\">";
  for (int k = 0; k <= 3; ++k) {
    absl::StrAppendFormat(&svg, "<stop offset=\"%.4f\" stop-color=\"%s\"/>", k / 3.0,
                          SvgColour(ScaleColour(k / 3.0)));
  }
  svg += "</linearGradient></defs>\n";
  svg += SvgText(l.density_title, s);
  const PixelBox& bar = l.density_bar;
  absl::StrAppendFormat(&svg,
                        "<rect x=\"%d\" y=\"%d\" width=\"%d\" height=\"%d\" "
                        "fill=\"url(#density-scale)\"/>\n",
                        bar.x, bar.y, bar.width, bar.height);
  for (const DensityTick& tick : l.density_ticks) {
    absl::StrAppendFormat(&svg,
                          "<rect x=\"%d\" y=\"%d\" width=\"%d\" height=\"%d\" fill=\"%s\"/>\n",
                          tick.x, bar.y + bar.height, s, l.tick_length, SvgColour(kTextColour));
    if (!tick.label.text.empty()) svg += SvgText(tick.label, s);
  }

  for (const LegendKey& key : l.keys) {
    const PixelBox& b = key.sample;
    switch (key.item) {
      case LegendItem::kNoPeople:
        svg += SvgBoxKey(b, kNoPeopleColour);
        break;
      case LegendItem::kNoFly:
        svg += SvgBoxKey(b, NoFlyTint(kNoPeopleColour));
        break;
      case LegendItem::kLandingSite:
        absl::StrAppendFormat(&svg,
                              "<rect x=\"%.1f\" y=\"%.1f\" width=\"6\" height=\"6\" fill=\"%s\" "
                              "stroke=\"white\" stroke-width=\"1\"/>\n",
                              CentreX(b) - 2.5, CentreY(b) - 2.5, SvgColour(kLandingSiteColour));
        break;
      case LegendItem::kTree:
        svg += SvgLineKey(b, 1.0, kTreeColour, kTreeAlpha);
        break;
      case LegendItem::kImprovement:
        svg += SvgLineKey(b, 1.2, ImprovementColour(0, improvements), kImprovementAlpha);
        break;
      case LegendItem::kFinal:
        svg += SvgLineKey(b, 3.0, ImprovementColour(improvements - 1, improvements), 1.0);
        break;
      case LegendItem::kStart:
        svg += SvgEndpointKey(b, kStartColour);
        break;
      case LegendItem::kGoal:
        svg += SvgEndpointKey(b, kGoalColour);
        break;
    }
    svg += SvgText(key.label, s);
  }

  absl::StrAppendFormat(&svg, "<rect x=\"%d\" y=\"%d\" width=\"%d\" height=\"%d\" fill=\"%s\"/>\n",
                        l.scale_bar.x, l.scale_bar.y, l.scale_bar.width, l.scale_bar.height,
                        SvgColour(kScaleBarColour));
  svg += SvgText(l.scale_label, s);
  return svg;
}

}  // namespace riskplan::client
