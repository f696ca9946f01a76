#include "tools/layer_writers.h"

#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>

#include "absl/strings/str_format.h"

namespace riskplan {

absl::Status WriteAsciiGrid(const RiskLayer& layer, const std::string& path) {
  std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(path.c_str(), "w"), &std::fclose);
  if (f == nullptr) return absl::InternalError(absl::StrFormat("cannot write '%s'", path));
  std::fprintf(f.get(), "ncols %d\nnrows %d\nxllcorner %.6f\nyllcorner %.6f\ncellsize %.6f\n",
               layer.nx, layer.ny, layer.x0, layer.y0, layer.res_m);
  // The format has no NaN: an undefined M is written as the NODATA value.
  std::fprintf(f.get(), "NODATA_value -9999\n");
  // ESRI ASCII grids list the northernmost row first.
  for (int r = layer.ny - 1; r >= 0; --r) {
    for (int c = 0; c < layer.nx; ++c) {
      const double m = layer.risk[static_cast<size_t>(r) * layer.nx + c];
      std::fprintf(f.get(), c == 0 ? "%.9g" : " %.9g", std::isnan(m) ? -9999.0 : m);
    }
    std::fputc('\n', f.get());
  }
  if (std::ferror(f.get())) return absl::InternalError(absl::StrFormat("error writing '%s'", path));
  return absl::OkStatus();
}

absl::Status WriteHeatMapPng(const RiskLayer& layer, const std::string& path) {
  std::vector<double> positive;
  for (double m : layer.risk) {
    if (m > 0.0) positive.push_back(std::log10(m));
  }
  double lo = 0.0;
  double hi = 1.0;
  // The colours span the 1st to the 99.9th percentile of log10 M (cells with
  // M > 0): a few extreme cells do not set the scale for all the others.
  if (!positive.empty()) {
    std::sort(positive.begin(), positive.end());
    lo = positive[static_cast<size_t>(0.01 * (positive.size() - 1))];
    hi = positive[static_cast<size_t>(0.999 * (positive.size() - 1))];
    if (!(hi > lo)) hi = lo + 1.0;
  }
  std::vector<png_byte> rgb(static_cast<size_t>(layer.nx) * layer.ny * 3);
  for (int r = 0; r < layer.ny; ++r) {
    const int row = layer.ny - 1 - r;  // north up
    for (int c = 0; c < layer.nx; ++c) {
      const double m = layer.risk[static_cast<size_t>(r) * layer.nx + c];
      png_byte* px = &rgb[(static_cast<size_t>(row) * layer.nx + c) * 3];
      if (std::isnan(m)) {
        px[0] = 128;
        px[1] = 128;
        px[2] = 128;
        continue;
      }
      if (!(m > 0.0)) {
        px[0] = 10;
        px[1] = 20;
        px[2] = 60;
        continue;
      }
      const double t = std::clamp((std::log10(m) - lo) / (hi - lo), 0.0, 1.0);
      // Black -> red -> yellow -> white.
      px[0] = static_cast<png_byte>(255.0 * std::min(1.0, 3.0 * t));
      px[1] = static_cast<png_byte>(255.0 * std::clamp(3.0 * t - 1.0, 0.0, 1.0));
      px[2] = static_cast<png_byte>(255.0 * std::clamp(3.0 * t - 2.0, 0.0, 1.0));
    }
  }
  std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(path.c_str(), "wb"), &std::fclose);
  if (f == nullptr) return absl::InternalError(absl::StrFormat("cannot write '%s'", path));
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png != nullptr ? png_create_info_struct(png) : nullptr;
  if (png == nullptr || info == nullptr) {
    png_destroy_write_struct(&png, &info);
    return absl::InternalError("libpng: cannot create a writer");
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return absl::InternalError(absl::StrFormat("libpng: error writing '%s'", path));
  }
  png_init_io(png, f.get());
  png_set_IHDR(png, info, layer.nx, layer.ny, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (int row = 0; row < layer.ny; ++row) {
    png_write_row(png, &rgb[static_cast<size_t>(row) * layer.nx * 3]);
  }
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return absl::OkStatus();
}

absl::StatusOr<std::string> LocalAzimuthalEquidistantWkt(const GeoReference& geo,
                                                         const std::string& map_name, double x0_m,
                                                         double y0_m) {
  const double lat = geo.origin_lat_deg;
  const double lon = geo.origin_lon_deg;
  if (!(lat >= -90.0 && lat <= 90.0) || !(lon >= -180.0 && lon <= 180.0) || !std::isfinite(x0_m) ||
      !std::isfinite(y0_m)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "geo-reference: origin (%.9g, %.9g) deg must have a latitude in [-90, 90] and a longitude "
        "in [-180, 180]",
        lat, lon));
  }
  // %.17g: every double round-trips, so the false origin is exactly the .asc's
  // frame. Map names are [a-z0-9._-], safe inside a WKT string.
  return absl::StrFormat(
      "PROJCS[\"riskplan_%s_local_AEQD\","
      "GEOGCS[\"GCS_WGS_1984\",DATUM[\"D_WGS_1984\","
      "SPHEROID[\"WGS_1984\",6378137.0,298.257223563]],"
      "PRIMEM[\"Greenwich\",0.0],UNIT[\"Degree\",0.0174532925199433]],"
      "PROJECTION[\"Azimuthal_Equidistant\"],"
      "PARAMETER[\"False_Easting\",%.17g],"
      "PARAMETER[\"False_Northing\",%.17g],"
      "PARAMETER[\"Central_Meridian\",%.17g],"
      "PARAMETER[\"Latitude_Of_Origin\",%.17g],"
      "UNIT[\"Meter\",1.0]]",
      map_name, x0_m, y0_m, lon, lat);
}

absl::Status WriteTextFile(const std::string& text, const std::string& path) {
  std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(path.c_str(), "w"), &std::fclose);
  if (f == nullptr) return absl::InternalError(absl::StrFormat("cannot write '%s'", path));
  if (std::fwrite(text.data(), 1, text.size(), f.get()) != text.size() || std::ferror(f.get())) {
    return absl::InternalError(absl::StrFormat("error writing '%s'", path));
  }
  return absl::OkStatus();
}

}  // namespace riskplan
