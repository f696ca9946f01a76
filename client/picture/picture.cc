#include "client/picture/picture.h"

#include <png.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <fstream>

#include "absl/strings/match.h"
#include "absl/strings/str_format.h"
#include "client/picture/bitmap_font.h"
#include "client/picture/picture_draw.h"
#include "client/picture/picture_layout.h"
#include "client/picture/picture_legend.h"
#include "geo/export/xml_text.h"

namespace riskplan::client {
namespace {

// Maps world metres onto the map's pixels, one pixel per layer cell, (0, 0)
// at the map's top-left corner. Map rows count from the south and image rows
// from the top, hence the flip in Y.
struct Projection {
  double x0, y0, cell_m;
  int height;
  double X(double x) const { return (x - x0) / cell_m; }
  double Y(double y) const { return height - (y - y0) / cell_m; }
};

// A zero cell size (a malformed response) is taken as 1 m, to draw
// something wrong rather than divide by zero.
Projection ProjectionOf(const PictureInput& in) {
  return {in.density.x0_m(), in.density.y0_m(), in.density.cell_m() > 0 ? in.density.cell_m() : 1,
          in.density.ny()};
}

// For the data: URI that embeds the raster in the SVG, so that the picture
// is one self-contained file.
std::string Base64(const std::string& data) {
  static const char kChars[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((data.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < data.size(); i += 3) {
    const uint32_t v = (static_cast<uint8_t>(data[i]) << 16) |
                       (static_cast<uint8_t>(data[i + 1]) << 8) | static_cast<uint8_t>(data[i + 2]);
    out += kChars[(v >> 18) & 63];
    out += kChars[(v >> 12) & 63];
    out += kChars[(v >> 6) & 63];
    out += kChars[v & 63];
  }
  if (i < data.size()) {
    uint32_t v = static_cast<uint8_t>(data[i]) << 16;
    if (i + 1 < data.size()) v |= static_cast<uint8_t>(data[i + 1]) << 8;
    out += kChars[(v >> 18) & 63];
    out += kChars[(v >> 12) & 63];
    out += i + 1 < data.size() ? kChars[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

void DrawPath(RgbaImage* img, const Projection& pr, const v1::Trajectory& t, double width, Rgb c,
              double alpha) {
  for (int i = 1; i < t.path_size(); ++i) {
    DrawLine(img, pr.X(t.path(i - 1).x()), pr.Y(t.path(i - 1).y()), pr.X(t.path(i).x()),
             pr.Y(t.path(i).y()), width, c, alpha);
  }
}

// The wind arrow: where it sits on the map (its centre), its half length,
// and its direction in image coordinates (x right, y down) where the air
// moves to. Empty when the wind is calm.
struct WindArrow {
  bool drawn = false;
  double cx = 0, cy = 0, half = 0, dx = 0, dy = 0;
  std::string speed_text, from_text;
};

WindArrow WindArrowOf(const PictureInput& in, int map_width) {
  WindArrow a;
  const double speed = in.wind.speed_mps();
  if (!(speed > 0.0)) return a;
  a.drawn = true;
  a.half = 18;
  a.cx = map_width - 42;
  a.cy = 34;
  const double norm = std::hypot(in.wind.x_mps(), in.wind.y_mps());
  a.dx = norm > 0 ? in.wind.x_mps() / norm : 0;
  a.dy = norm > 0 ? -in.wind.y_mps() / norm : 0;  // north is up
  a.speed_text = absl::StrFormat("wind %g m/s", speed);
  a.from_text = absl::StrFormat("from %.0f deg", in.wind.from_deg());
  return a;
}

Rgb FleetTrajectoryColour(const PictureInput& in, size_t k) {
  return in.fleet_key ? FleetColour(k) : ImprovementColour(1, 2);
}

// The PNG's wind arrow and the key of the fleet's labels, drawn last.
void DrawWindAndKey(RgbaImage* img, const PictureInput& in) {
  const auto text = [&](const std::string& t, int x, int y) {
    ForEachTextPixel(t, 1, [&](int px, int py) { Stamp(img, x + px, y + py, 1, kTextColour, 1.0); });
  };
  const WindArrow a = WindArrowOf(in, img->width);
  if (a.drawn) {
    const int w = std::max(TextWidth(a.speed_text, 1), TextWidth(a.from_text, 1)) + 8;
    for (int y = 6; y < 6 + 2 * static_cast<int>(a.half) + 26; ++y) {
      DrawLine(img, a.cx - w / 2.0, y, a.cx + w / 2.0, y, 1, {255, 255, 255}, 0.8);
    }
    const double x0 = a.cx - a.dx * a.half, y0 = a.cy - a.dy * a.half;
    const double x1 = a.cx + a.dx * a.half, y1 = a.cy + a.dy * a.half;
    DrawLine(img, x0, y0, x1, y1, 2, kWindColour, 1.0);
    // The head: two strokes back from the tip at +-30 degrees.
    for (double s : {0.5, -0.5}) {
      const double c = std::cos(s), sn = std::sin(s);
      const double bx = -(a.dx * c - a.dy * sn), by = -(a.dx * sn + a.dy * c);
      DrawLine(img, x1, y1, x1 + 8 * bx, y1 + 8 * by, 2, kWindColour, 1.0);
    }
    text(a.speed_text, static_cast<int>(a.cx) - TextWidth(a.speed_text, 1) / 2,
         static_cast<int>(a.cy + a.half) + 4);
    text(a.from_text, static_cast<int>(a.cx) - TextWidth(a.from_text, 1) / 2,
         static_cast<int>(a.cy + a.half) + 14);
  }
  if (in.fleet_key) {
    for (size_t k = 0; k < in.fleet.size() && k < in.fleet_labels.size(); ++k) {
      const int y = 10 + 12 * static_cast<int>(k);
      DrawLine(img, 8, y + 3, 28, y + 3, 3, FleetColour(k), 1.0);
      text(in.fleet_labels[k], 34, y);
    }
  }
}

std::string SvgWindAndKey(const PictureInput& in, int map_width) {
  std::string svg;
  const WindArrow a = WindArrowOf(in, map_width);
  if (a.drawn) {
    const double x0 = a.cx - a.dx * a.half, y0 = a.cy - a.dy * a.half;
    const double x1 = a.cx + a.dx * a.half, y1 = a.cy + a.dy * a.half;
    absl::StrAppendFormat(
        &svg,
        "<g class=\"wind\"><title>%s, %s (grid north)</title>"
        "<rect x=\"%.1f\" y=\"4\" width=\"76\" height=\"%.1f\" rx=\"4\" fill=\"white\" "
        "fill-opacity=\"0.8\"/>"
        "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"%s\" stroke-width=\"2.5\"/>"
        "<polygon points=\"%.1f,%.1f %.1f,%.1f %.1f,%.1f\" fill=\"%s\"/>"
        "<text x=\"%.1f\" y=\"%.1f\" font-family=\"sans-serif\" font-size=\"10\" "
        "text-anchor=\"middle\" fill=\"%s\">%s</text>"
        "<text x=\"%.1f\" y=\"%.1f\" font-family=\"sans-serif\" font-size=\"10\" "
        "text-anchor=\"middle\" fill=\"%s\">%s</text></g>\n",
        a.speed_text, a.from_text, a.cx - 38, 2 * a.half + 46, x0, y0, x1 - 6 * a.dx,
        y1 - 6 * a.dy, SvgColour(kWindColour), x1, y1, x1 - 9 * a.dx - 5 * a.dy,
        y1 - 9 * a.dy + 5 * a.dx, x1 - 9 * a.dx + 5 * a.dy, y1 - 9 * a.dy - 5 * a.dx,
        SvgColour(kWindColour), a.cx, a.cy + a.half + 12, SvgColour(kTextColour), a.speed_text,
        a.cx, a.cy + a.half + 24, SvgColour(kTextColour), a.from_text);
  }
  if (in.fleet_key) {
    for (size_t k = 0; k < in.fleet.size() && k < in.fleet_labels.size(); ++k) {
      const double y = 14 + 16 * static_cast<double>(k);
      absl::StrAppendFormat(
          &svg,
          "<rect x=\"4\" y=\"%.1f\" width=\"%d\" height=\"15\" fill=\"white\" "
          "fill-opacity=\"0.8\"/><line x1=\"8\" y1=\"%.1f\" x2=\"30\" y2=\"%.1f\" "
          "stroke=\"%s\" stroke-width=\"3\"/><text x=\"36\" y=\"%.1f\" "
          "font-family=\"sans-serif\" font-size=\"11\" fill=\"%s\">%s</text>\n",
          y - 10, 40 + 7 * static_cast<int>(in.fleet_labels[k].size()), y - 3, y - 3,
          SvgColour(FleetColour(k)), y, SvgColour(kTextColour), geo::XmlEscape(in.fleet_labels[k]));
    }
  }
  return svg;
}

// The map's raster with the tree, the improvements, the landing sites and
// the start and goal drawn on it, bottom to top. Drawn on the map alone, so
// that a trajectory leaving the map is cut at its edge.
RgbaImage RenderMap(const PictureInput& in) {
  RgbaImage img = RenderMapRaster(in);
  const Projection pr = ProjectionOf(in);
  for (const v1::TreeEdge& e : in.tree) {
    DrawLine(&img, pr.X(e.from().x()), pr.Y(e.from().y()), pr.X(e.to().x()), pr.Y(e.to().y()), 1,
             kTreeColour, kTreeAlpha);
  }
  const size_t n = in.improvements.size();
  for (size_t k = 0; k < n; ++k) {
    const bool final = k + 1 == n;
    DrawPath(&img, pr, in.improvements[k], final ? kFinalWidth : kImprovementWidth,
             ImprovementColour(k, n), final ? 1.0 : kImprovementAlpha);
  }
  for (size_t k = 0; k < in.fleet.size(); ++k) {
    DrawPath(&img, pr, in.fleet[k], kFinalWidth, FleetTrajectoryColour(in, k), 1.0);
  }
  for (const v1::LandingSite& site : in.map.landing_sites()) {
    DrawDisc(&img, pr.X(site.x()), pr.Y(site.y()), kLandingSiteRadius, kLandingSiteColour);
  }
  for (const v1::Pose& p : in.fleet_starts) {
    DrawDisc(&img, pr.X(p.x()), pr.Y(p.y()), kEndpointRadius, kStartColour);
  }
  DrawDisc(&img, pr.X(in.start.x()), pr.Y(in.start.y()), kEndpointRadius, kStartColour);
  DrawDisc(&img, pr.X(in.goal.x()), pr.Y(in.goal.y()), kEndpointRadius, kGoalColour);
  DrawWindAndKey(&img, in);
  return img;
}

std::string SvgPoints(const Projection& pr, const v1::Trajectory& t) {
  std::string out;
  for (const v1::Pose& p : t.path())
    absl::StrAppendFormat(&out, "%.1f,%.1f ", pr.X(p.x()), pr.Y(p.y()));
  return out;
}

}  // namespace

absl::StatusOr<std::string> EncodePng(const RgbaImage& image) {
  assert(image.pixels.size() == static_cast<size_t>(image.width) * image.height * 4);
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  if (png == nullptr) return absl::InternalError("png_create_write_struct failed");
  png_infop info = png_create_info_struct(png);
  // libpng reports an error by longjmp back to this setjmp. `out` is
  // declared before it, because a longjmp must not skip the destructor of an
  // object created after the setjmp; nothing after it owns memory.
  std::string out;
  if (info == nullptr || setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return absl::InternalError("PNG encoding failed");
  }
  // Into memory, not a FILE*: the SVG embeds the bytes, and WritePicture
  // writes them with the same error check as the SVG's.
  png_set_write_fn(
      png, &out,
      [](png_structp p, png_bytep data, png_size_t size) {
        static_cast<std::string*>(png_get_io_ptr(p))->append(reinterpret_cast<char*>(data), size);
      },
      nullptr);
  png_set_IHDR(png, info, image.width, image.height, 8, PNG_COLOR_TYPE_RGBA, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (int y = 0; y < image.height; ++y) {
    png_write_row(png,
                  const_cast<png_bytep>(&image.pixels[static_cast<size_t>(y) * image.width * 4]));
  }
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return out;
}

RgbaImage RenderMapRaster(const PictureInput& in) {
  assert(in.density.nx() >= 0 && in.density.ny() >= 0 &&
         in.density.values_size() == static_cast<int64_t>(in.density.nx()) * in.density.ny());
  RgbaImage img;
  img.width = in.density.nx();
  img.height = in.density.ny();
  img.pixels.assign(static_cast<size_t>(img.width) * img.height * 4, 255);
  const double high = DensityScaleHigh(in.density);
  // No-fly zones are drawn only when their layer came on the density's grid;
  // otherwise (absent, or a mismatched response) the map is drawn without.
  const bool has_nofly = in.nofly.nx() == img.width && in.nofly.ny() == img.height &&
                         in.nofly.values_size() == in.density.values_size();
  for (int j = 0; j < img.height; ++j) {
    for (int i = 0; i < img.width; ++i) {
      const int src = j * img.width + i;  // row 0 is the southernmost
      Rgb c = DensityColour(in.density.values(src), high);
      if (has_nofly && in.nofly.values(src) > 0.5f) c = NoFlyTint(c);
      uint8_t* p = &img.pixels[(static_cast<size_t>(img.height - 1 - j) * img.width + i) * 4];
      p[0] = static_cast<uint8_t>(c.r);
      p[1] = static_cast<uint8_t>(c.g);
      p[2] = static_cast<uint8_t>(c.b);
      p[3] = 255;
    }
  }
  return img;
}

RgbaImage RenderPicture(const PictureInput& in) {
  const PictureLayout layout = LayoutPicture(in);
  RgbaImage img;
  img.width = layout.width;
  img.height = layout.height;
  img.pixels.assign(static_cast<size_t>(img.width) * img.height * 4, 255);
  const RgbaImage map = RenderMap(in);
  for (int y = 0; y < map.height; ++y) {
    std::copy_n(
        &map.pixels[static_cast<size_t>(y) * map.width * 4], map.width * 4,
        &img.pixels[(static_cast<size_t>(layout.map.y + y) * img.width + layout.map.x) * 4]);
  }
  DrawCaptionAndLegend(&img, layout, in.improvements.size());
  return img;
}

// The raster (density and no-fly) is embedded as a PNG and everything drawn
// on it is vector, so lines stay sharp when zoomed and each improvement can
// carry a tooltip with its risk. The map's elements are in its own
// coordinates (a group moved to the map's place and clipped to it), drawn
// bottom to top: raster, landing sites, tree, improvements from the first to
// the best, start and goal.
std::string RenderSvg(const PictureInput& in) {
  assert(in.density.nx() >= 0 && in.density.ny() >= 0 &&
         in.density.values_size() == static_cast<int64_t>(in.density.nx()) * in.density.ny());
  const PictureLayout layout = LayoutPicture(in);
  const Projection pr = ProjectionOf(in);
  const int w = layout.map.width, h = layout.map.height;
  std::string svg = absl::StrFormat(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%d\" height=\"%d\" "
      "viewBox=\"0 0 %d %d\">\n"
      "<rect x=\"0\" y=\"0\" width=\"%d\" height=\"%d\" fill=\"white\"/>\n",
      layout.width, layout.height, layout.width, layout.height, layout.width, layout.height);
  absl::StrAppendFormat(&svg,
                        "<clipPath id=\"map\"><rect x=\"0\" y=\"0\" width=\"%d\" "
                        "height=\"%d\"/></clipPath>\n"
                        "<g transform=\"translate(%d,%d)\" clip-path=\"url(#map)\">\n",
                        w, h, layout.map.x, layout.map.y);
  // "pixelated" keeps map cells square when a viewer scales the image up; a
  // raster that failed to encode leaves the picture without a background
  // rather than without the trajectories.
  absl::StatusOr<std::string> png = EncodePng(RenderMapRaster(in));
  if (png.ok()) {
    absl::StrAppendFormat(&svg,
                          "<image x=\"0\" y=\"0\" width=\"%d\" height=\"%d\" "
                          "style=\"image-rendering:pixelated\" "
                          "href=\"data:image/png;base64,%s\"/>\n",
                          w, h, Base64(*png));
  }
  for (const v1::LandingSite& site : in.map.landing_sites()) {
    absl::StrAppendFormat(&svg,
                          "<rect x=\"%.1f\" y=\"%.1f\" width=\"6\" height=\"6\" fill=\"%s\" "
                          "stroke=\"white\" stroke-width=\"1\"/>\n",
                          pr.X(site.x()) - 3, pr.Y(site.y()) - 3, SvgColour(kLandingSiteColour));
  }
  if (!in.tree.empty()) {
    absl::StrAppendFormat(&svg, "<g stroke=\"%s\" stroke-width=\"0.5\" stroke-opacity=\"0.35\">\n",
                          SvgColour(kTreeColour));
    for (const v1::TreeEdge& e : in.tree) {
      absl::StrAppendFormat(&svg, "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\"/>\n",
                            pr.X(e.from().x()), pr.Y(e.from().y()), pr.X(e.to().x()),
                            pr.Y(e.to().y()));
    }
    svg += "</g>\n";
  }
  const size_t n = in.improvements.size();
  for (size_t k = 0; k < n; ++k) {
    const bool best = k + 1 == n;
    absl::StrAppendFormat(
        &svg,
        "<polyline fill=\"none\" stroke=\"%s\" stroke-width=\"%.1f\" stroke-opacity=\"%.2f\" "
        "points=\"%s\"><title>improvement %d: risk %.6g, length %.0f m</title></polyline>\n",
        SvgColour(ImprovementColour(k, n)), best ? 3.0 : 1.2, best ? 1.0 : kImprovementAlpha,
        SvgPoints(pr, in.improvements[k]), k + 1, in.improvements[k].risk(),
        in.improvements[k].length_m());
  }
  for (size_t k = 0; k < in.fleet.size(); ++k) {
    absl::StrAppendFormat(
        &svg,
        "<polyline fill=\"none\" stroke=\"%s\" stroke-width=\"3.0\" points=\"%s\"><title>%s: "
        "risk %.6g, length %.0f m</title></polyline>\n",
        SvgColour(FleetTrajectoryColour(in, k)), SvgPoints(pr, in.fleet[k]),
        k < in.fleet_labels.size() ? geo::XmlEscape(in.fleet_labels[k]) : "", in.fleet[k].risk(),
        in.fleet[k].length_m());
  }
  for (const v1::Pose& p : in.fleet_starts) {
    absl::StrAppendFormat(&svg,
                          "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"5\" fill=\"%s\" "
                          "stroke=\"white\" stroke-width=\"2\"/>\n",
                          pr.X(p.x()), pr.Y(p.y()), SvgColour(kStartColour));
  }
  absl::StrAppendFormat(&svg,
                        "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"7\" fill=\"%s\" "
                        "stroke=\"white\" stroke-width=\"2\"><title>start</title></circle>\n"
                        "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"7\" fill=\"%s\" "
                        "stroke=\"white\" stroke-width=\"2\"><title>goal</title></circle>\n",
                        pr.X(in.start.x()), pr.Y(in.start.y()), SvgColour(kStartColour),
                        pr.X(in.goal.x()), pr.Y(in.goal.y()), SvgColour(kGoalColour));
  svg += SvgWindAndKey(in, w);
  svg += "</g>\n";
  svg += SvgCaptionAndLegend(layout, n);
  svg += "</svg>\n";
  return svg;
}

absl::Status WritePicture(const std::string& path, const PictureInput& in) {
  // The layers come from the server: a response that does not hold nx * ny
  // values is refused here, before the renderers index it.
  if (in.density.nx() <= 0 || in.density.ny() <= 0) {
    return absl::InvalidArgumentError("picture: the density layer is empty");
  }
  if (in.density.values_size() != static_cast<int64_t>(in.density.nx()) * in.density.ny()) {
    return absl::InvalidArgumentError(
        absl::StrFormat("picture: the density layer has %d values for %d x %d cells",
                        in.density.values_size(), in.density.nx(), in.density.ny()));
  }
  std::string bytes;
  if (absl::EndsWith(path, ".svg")) {
    bytes = RenderSvg(in);
  } else if (absl::EndsWith(path, ".png")) {
    absl::StatusOr<std::string> png = EncodePng(RenderPicture(in));
    if (!png.ok()) return png.status();
    bytes = *std::move(png);
  } else {
    return absl::InvalidArgumentError(
        absl::StrFormat("picture '%s': the name must end in .svg or .png", path));
  }
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  // Closed before the check, so that a failure to flush (a full disk) is
  // reported too.
  out.close();
  if (!out) return absl::UnavailableError(absl::StrFormat("cannot write picture '%s'", path));
  return absl::OkStatus();
}

}  // namespace riskplan::client
