// What the importer's steps share: the refusal that names the cells an input
// leaves without data, and the fill rules.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_format.h"
#include "core/base/check.h"
#include "geo/import_steps.h"

namespace riskplan::geo::internal {
namespace {

// Points per edge when the missing cells' box is carried into WGS84 and the
// input's CRS: its edges are curves there, so more than the corners count.
constexpr int kEdgePoints = 16;

struct Range {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void Add(double v) {
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  bool valid() const { return lo <= hi; }
};

}  // namespace

absl::Status MissingCellsError(const ImportContext& ctx, const std::string& label,
                               const OGRSpatialReference* input_srs,
                               const std::vector<uint8_t>& missing,
                               const std::vector<uint8_t>& outside, const std::string& fix) {
  const TargetGrid& g = ctx.grid;
  int64_t count = 0, beyond = 0;
  int i_min = g.nx, i_max = -1, j_min = g.ny, j_max = -1;
  for (int j = 0; j < g.ny; ++j) {
    for (int i = 0; i < g.nx; ++i) {
      const size_t c = static_cast<size_t>(j) * g.nx + i;
      if (missing[c] == 0) continue;
      ++count;
      if (!outside.empty() && outside[c] != 0) ++beyond;
      i_min = std::min(i_min, i);
      i_max = std::max(i_max, i);
      j_min = std::min(j_min, j);
      j_max = std::max(j_max, j);
    }
  }
  const double x0 = g.frame.x0() + i_min * g.res_m, x1 = g.frame.x0() + (i_max + 1) * g.res_m;
  const double y0 = g.frame.y0() + j_min * g.res_m, y1 = g.frame.y0() + (j_max + 1) * g.res_m;
  std::vector<LocalXY> outline;
  for (int k = 0; k <= kEdgePoints; ++k) {
    const double t = static_cast<double>(k) / kEdgePoints;
    outline.push_back({x0 + t * (x1 - x0), y0});
    outline.push_back({x0 + t * (x1 - x0), y1});
    outline.push_back({x0, y0 + t * (y1 - y0)});
    outline.push_back({x1, y0 + t * (y1 - y0)});
  }
  std::string wgs84 = "(unknown)";
  if (auto ll = g.frame.ToWgs84(outline); ll.ok()) {
    Range lat, lon;
    for (const LatLon& p : *ll) {
      lat.Add(p.lat_deg);
      lon.Add(p.lon_deg);
    }
    wgs84 =
        absl::StrFormat("lat %.6f .. %.6f, lon %.6f .. %.6f deg", lat.lo, lat.hi, lon.lo, lon.hi);
  }
  std::string in_crs = "(cannot be carried into it)";
  if (input_srs != nullptr) {
    if (auto ct = TransformationBetween(*ctx.frame_srs, *input_srs); ct.ok()) {
      std::vector<double> xs, ys;
      for (const LocalXY& p : outline) {
        xs.push_back(p.x);
        ys.push_back(p.y);
      }
      std::vector<int> ok(xs.size());
      (*ct)->Transform(static_cast<int>(xs.size()), xs.data(), ys.data(), nullptr, ok.data());
      Range rx, ry;
      for (size_t k = 0; k < xs.size(); ++k) {
        if (ok[k] && std::isfinite(xs[k]) && std::isfinite(ys[k])) {
          rx.Add(xs[k]);
          ry.Add(ys[k]);
        }
      }
      if (rx.valid()) {
        const bool geographic = IsGeographic(*input_srs);
        // Two calls: absl checks a format string at compile time only when it
        // is a constant (clang refuses a conditional one).
        in_crs = geographic ? absl::StrFormat("%s lon %.6f .. %.6f, lat %.6f .. %.6f deg",
                                              CrsShortName(input_srs), rx.lo, rx.hi, ry.lo, ry.hi)
                            : absl::StrFormat("%s x %.3f .. %.3f, y %.3f .. %.3f",
                                              CrsShortName(input_srs), rx.lo, rx.hi, ry.lo, ry.hi);
      }
    }
  }
  std::string what =
      outside.empty()
          ? absl::StrFormat("%d of %d cells lie in no feature of the input", count, g.cells())
          : absl::StrFormat(
                "%d of %d cells have no data (%d outside the input's extent, %d masked inside it: "
                "nodata value, mask band or alpha)",
                count, g.cells(), beyond, count - beyond);
  return absl::InvalidArgumentError(absl::StrFormat(
      "%s: %s; they span cells (%d .. %d, %d .. %d), local x %.1f .. %.1f m, y %.1f .. %.1f m; "
      "WGS84 %s; input CRS %s; give an input that covers the map, or %s",
      label, what, i_min, i_max, j_min, j_max, x0, x1, y0, y1, wgs84, in_crs, fix));
}

int64_t FillMissing(const FillRule& rule, int nx, int ny, std::vector<double>* values) {
  RISKPLAN_DCHECK(rule.kind != FillRule::Kind::kNone);
  RISKPLAN_DCHECK(values->size() == static_cast<size_t>(nx) * ny);
  std::vector<double>& v = *values;
  int64_t filled = 0;
  if (rule.kind == FillRule::Kind::kValue) {
    for (double& x : v) {
      if (std::isnan(x)) {
        x = rule.value;
        ++filled;
      }
    }
    return filled;
  }
  // Nearest: a 3-4 chamfer transform that carries, with each distance, the
  // index of the cell it was measured from.
  constexpr int kInf = std::numeric_limits<int>::max() / 2;
  std::vector<int> d(v.size());
  std::vector<int64_t> from(v.size(), -1);
  for (size_t c = 0; c < v.size(); ++c) {
    if (std::isnan(v[c])) {
      d[c] = kInf;
    } else {
      d[c] = 0;
      from[c] = static_cast<int64_t>(c);
    }
  }
  auto relax = [&](size_t c, int i, int j, int step) {
    if (i < 0 || j < 0 || i >= nx || j >= ny) return;
    const size_t n = static_cast<size_t>(j) * nx + i;
    if (from[n] >= 0 && d[n] + step < d[c]) {
      d[c] = d[n] + step;
      from[c] = from[n];
    }
  };
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const size_t c = static_cast<size_t>(j) * nx + i;
      relax(c, i - 1, j, 3);
      relax(c, i, j - 1, 3);
      relax(c, i - 1, j - 1, 4);
      relax(c, i + 1, j - 1, 4);
    }
  }
  for (int j = ny - 1; j >= 0; --j) {
    for (int i = nx - 1; i >= 0; --i) {
      const size_t c = static_cast<size_t>(j) * nx + i;
      relax(c, i + 1, j, 3);
      relax(c, i, j + 1, 3);
      relax(c, i + 1, j + 1, 4);
      relax(c, i - 1, j + 1, 4);
    }
  }
  for (size_t c = 0; c < v.size(); ++c) {
    if (std::isnan(v[c]) && from[c] >= 0) {
      v[c] = v[from[c]];
      ++filled;
    }
  }
  return filled;
}

}  // namespace riskplan::geo::internal
