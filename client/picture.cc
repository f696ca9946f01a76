#include "client/picture.h"

#include <png.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <fstream>

#include "absl/strings/match.h"
#include "absl/strings/str_format.h"

namespace riskplan::client {
namespace {

struct Rgb {
  double r, g, b;
};

// Density colour: pale for empty land, then yellow, orange and dark red on a
// log scale from 1e-5 to the map's densest block. Logarithmic because
// densities span orders of magnitude (a park, a suburb, a centre): on a
// linear scale only the densest blocks would show. The top is at least 1e-4
// so that the scale spans a decade even on an empty map (no division by
// log 1 = 0).
Rgb DensityColour(float density, float max_density) {
  if (!(density > 1e-5f)) return {236, 240, 230};
  const double top = std::max(1e-4, static_cast<double>(max_density));
  const double t = std::clamp(std::log10(density / 1e-5) / std::log10(top / 1e-5), 0.0, 1.0);
  static const Rgb kStops[] = {{250, 246, 214}, {255, 214, 110}, {240, 120, 40}, {120, 0, 30}};
  const double pos = t * 3.0;
  const int i = std::min(2, static_cast<int>(pos));
  const double f = pos - i;
  return {kStops[i].r + (kStops[i + 1].r - kStops[i].r) * f,
          kStops[i].g + (kStops[i + 1].g - kStops[i].g) * f,
          kStops[i].b + (kStops[i + 1].b - kStops[i].b) * f};
}

// Maps world metres onto the picture's pixels, one pixel per layer cell.
// Map rows count from the south and image rows from the top, hence the flip
// in Y.
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

// Colour of improvement `k` of `n`: from light blue (first) to dark blue.
Rgb ImprovementColour(size_t k, size_t n) {
  const double t = n <= 1 ? 1.0 : static_cast<double>(k) / (n - 1);
  return {150 - 150 * t, 190 - 150 * t, 255 - 55 * t};
}

// Blends a square brush of side `width` px centred on (x, y). Pixels off the
// image are skipped, so a trajectory may leave the map. Alpha stays 255: the
// raster under the drawing is opaque.
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

// Stamps one brush per pixel along the longer axis: dense enough for a
// gap-free line, and simple, since the picture needs no anti-aliasing.
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

void DrawPath(RgbaImage* img, const Projection& pr, const v1::Trajectory& t, double width, Rgb c,
              double alpha) {
  for (int i = 1; i < t.path_size(); ++i) {
    DrawLine(img, pr.X(t.path(i - 1).x()), pr.Y(t.path(i - 1).y()), pr.X(t.path(i).x()),
             pr.Y(t.path(i).y()), width, c, alpha);
  }
}

void DrawDisc(RgbaImage* img, double x, double y, double radius, Rgb c) {
  for (double dy = -radius; dy <= radius; dy += 1) {
    for (double dx = -radius; dx <= radius; dx += 1) {
      if (dx * dx + dy * dy <= radius * radius) Stamp(img, x + dx, y + dy, 1, c, 1.0);
    }
  }
}

std::string SvgPoints(const Projection& pr, const v1::Trajectory& t) {
  std::string out;
  for (const v1::Pose& p : t.path())
    absl::StrAppendFormat(&out, "%.1f,%.1f ", pr.X(p.x()), pr.Y(p.y()));
  return out;
}

std::string SvgColour(Rgb c) {
  return absl::StrFormat("rgb(%d,%d,%d)", static_cast<int>(c.r), static_cast<int>(c.g),
                         static_cast<int>(c.b));
}

// The caption holds names from the server (the map's); escaped so that a
// name with '<' or '&' cannot break the document. Quotes need no escape in
// element text.
std::string XmlEscape(const std::string& text) {
  std::string out;
  for (char ch : text) {
    switch (ch) {
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '&':
        out += "&amp;";
        break;
      default:
        out += ch;
    }
  }
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
  float max_density = 0.0f;
  for (float d : in.density.values()) max_density = std::max(max_density, d);
  // No-fly zones are drawn only when their layer came on the density's grid;
  // otherwise (absent, or a mismatched response) the map is drawn without.
  const bool has_nofly = in.nofly.nx() == img.width && in.nofly.ny() == img.height &&
                         in.nofly.values_size() == in.density.values_size();
  for (int j = 0; j < img.height; ++j) {
    for (int i = 0; i < img.width; ++i) {
      const int src = j * img.width + i;  // row 0 is the southernmost
      Rgb c = DensityColour(in.density.values(src), max_density);
      if (has_nofly && in.nofly.values(src) > 0.5f) {
        // Violet, which the density scale never uses.
        c = {c.r + (110 - c.r) * 0.65, c.g + (40 - c.g) * 0.65, c.b + (190 - c.b) * 0.65};
      }
      uint8_t* p = &img.pixels[(static_cast<size_t>(img.height - 1 - j) * img.width + i) * 4];
      p[0] = static_cast<uint8_t>(c.r);
      p[1] = static_cast<uint8_t>(c.g);
      p[2] = static_cast<uint8_t>(c.b);
      p[3] = 255;
    }
  }
  return img;
}

// The raster (density and no-fly) is embedded as a PNG and everything drawn
// on it is vector, so lines stay sharp when zoomed and each improvement can
// carry a tooltip with its risk. Drawn bottom to top: raster, landing sites,
// tree, improvements from the first to the best, start and goal.
std::string RenderSvg(const PictureInput& in) {
  assert(in.density.nx() >= 0 && in.density.ny() >= 0 &&
         in.density.values_size() == static_cast<int64_t>(in.density.nx()) * in.density.ny());
  const Projection pr = ProjectionOf(in);
  const int w = in.density.nx(), h = in.density.ny();
  const int caption_h = 28;
  std::string svg = absl::StrFormat(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%d\" height=\"%d\" "
      "viewBox=\"0 %d %d %d\">\n",
      w, h + caption_h, -caption_h, w, h + caption_h);
  absl::StrAppendFormat(&svg,
                        "<rect x=\"0\" y=\"%d\" width=\"%d\" height=\"%d\" fill=\"white\"/>\n"
                        "<text x=\"6\" y=\"-9\" font-family=\"sans-serif\" font-size=\"14\">%s"
                        "</text>\n",
                        -caption_h, w, caption_h, XmlEscape(in.caption));
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
    absl::StrAppendFormat(
        &svg,
        "<rect x=\"%.1f\" y=\"%.1f\" width=\"6\" height=\"6\" fill=\"rgb(20,150,60)\" "
        "stroke=\"white\" stroke-width=\"1\"/>\n",
        pr.X(site.x()) - 3, pr.Y(site.y()) - 3);
  }
  if (!in.tree.empty()) {
    svg += "<g stroke=\"rgb(70,70,70)\" stroke-width=\"0.5\" stroke-opacity=\"0.35\">\n";
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
        SvgColour(ImprovementColour(k, n)), best ? 3.0 : 1.2, best ? 1.0 : 0.7,
        SvgPoints(pr, in.improvements[k]), k + 1, in.improvements[k].risk(),
        in.improvements[k].length_m());
  }
  absl::StrAppendFormat(&svg,
                        "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"7\" fill=\"rgb(0,170,70)\" "
                        "stroke=\"white\" stroke-width=\"2\"><title>start</title></circle>\n"
                        "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"7\" fill=\"rgb(200,0,160)\" "
                        "stroke=\"white\" stroke-width=\"2\"><title>goal</title></circle>\n",
                        pr.X(in.start.x()), pr.Y(in.start.y()), pr.X(in.goal.x()),
                        pr.Y(in.goal.y()));
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
    RgbaImage img = RenderMapRaster(in);
    const Projection pr = ProjectionOf(in);
    for (const v1::TreeEdge& e : in.tree) {
      DrawLine(&img, pr.X(e.from().x()), pr.Y(e.from().y()), pr.X(e.to().x()), pr.Y(e.to().y()), 1,
               {70, 70, 70}, 0.3);
    }
    for (size_t k = 0; k < in.improvements.size(); ++k) {
      const bool best = k + 1 == in.improvements.size();
      DrawPath(&img, pr, in.improvements[k], best ? 3 : 1,
               ImprovementColour(k, in.improvements.size()), best ? 1.0 : 0.7);
    }
    for (const v1::LandingSite& site : in.map.landing_sites()) {
      DrawDisc(&img, pr.X(site.x()), pr.Y(site.y()), 3, {20, 150, 60});
    }
    DrawDisc(&img, pr.X(in.start.x()), pr.Y(in.start.y()), 6, {0, 170, 70});
    DrawDisc(&img, pr.X(in.goal.x()), pr.Y(in.goal.y()), 6, {200, 0, 160});
    absl::StatusOr<std::string> png = EncodePng(img);
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
