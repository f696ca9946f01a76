// The terrain step: a DEM warped bilinearly onto the grid.
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/ascii.h"
#include "absl/strings/str_format.h"
#include "geo/import_steps.h"
#include "geo/raster_input.h"

namespace riskplan::geo::internal {
namespace {

// Below the Dead Sea shore or above Everest: an undeclared nodata value
// (-32768, -9999) or a DEM in other units, never a real ground height.
constexpr double kLowestTerrainM = -500.0;
constexpr double kHighestTerrainM = 9000.0;

// Metres per unit of the band's unit type, or 0 for a unit that is not a
// length GDAL's DEMs use.
double MetresPerUnit(std::string unit) {
  unit = absl::AsciiStrToLower(absl::StripAsciiWhitespace(unit));
  if (unit.empty() || unit == "m" || unit == "metre" || unit == "meter" || unit == "metres" ||
      unit == "meters") {
    return 1.0;
  }
  if (unit == "ft" || unit == "foot" || unit == "feet" || unit == "international foot") {
    return 0.3048;
  }
  if (unit == "us survey foot" || unit == "ftus" || unit == "us-ft") return 1200.0 / 3937.0;
  return 0.0;
}

}  // namespace

absl::StatusOr<std::vector<float>> ImportTerrain(ImportContext& ctx) {
  const ImportOptions& o = ctx.options;
  auto in = OpenRasterInput("terrain", o.terrain);
  if (!in.ok()) return in.status();
  const std::string unit = in->dataset->GetRasterBand(1)->GetUnitType();
  const double to_m = MetresPerUnit(unit);
  if (to_m == 0.0) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s: its heights are in '%s'; the terrain must be in metres (or feet)", in->Label(), unit));
  }
  // Bilinear: the terrain is a surface, sampled at each cell's centre.
  auto values = WarpOntoGrid(*in, ctx.grid, Resampling::kBilinear, o.threads);
  if (!values.ok()) return values.status();
  std::vector<uint8_t> missing(values->size());
  bool any_missing = false;
  for (size_t c = 0; c < values->size(); ++c) {
    missing[c] = std::isnan((*values)[c]) ? 1 : 0;
    any_missing = any_missing || missing[c] != 0;
  }
  if (any_missing) {
    if (o.terrain_fill.kind == FillRule::Kind::kNone) {
      auto footprint = InputFootprint(*in, ctx.grid);
      if (!footprint.ok()) return footprint.status();
      // Outside the footprint: the refusal tells the cells beyond the DEM's
      // extent from those masked inside it.
      for (uint8_t& f : *footprint) f = f == 0 ? 1 : 0;
      return MissingCellsError(ctx, in->Label(), in->srs.get(), missing, *footprint,
                               "--fill_terrain=METRES|nearest");
    }
    ctx.out->stats.filled_terrain_cells =
        FillMissing(o.terrain_fill, ctx.grid.nx, ctx.grid.ny, &*values);
  }
  std::vector<float> terrain(values->size());
  double lo = INFINITY, hi = -INFINITY;
  for (size_t c = 0; c < values->size(); ++c) {
    const double metres = (*values)[c] * to_m;
    if (!(metres >= kLowestTerrainM && metres <= kHighestTerrainM)) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "%s: cell (%d, %d) has terrain %.9g m, outside [%g, %g] m: a nodata value the file does "
          "not declare (declare it, e.g. gdal_translate -a_nodata -32768), or not metres",
          in->Label(), static_cast<int>(c % ctx.grid.nx), static_cast<int>(c / ctx.grid.nx), metres,
          kLowestTerrainM, kHighestTerrainM));
    }
    terrain[c] = static_cast<float>(metres);
    lo = std::min(lo, metres);
    hi = std::max(hi, metres);
  }
  ctx.out->stats.terrain_min_m = lo;
  ctx.out->stats.terrain_max_m = hi;
  std::string detail = absl::StrFormat("%s; resampling bilinear", in->Summary());
  if (to_m != 1.0) detail += absl::StrFormat("; heights in '%s' converted to metres", unit);
  if (ctx.out->stats.filled_terrain_cells > 0) {
    detail +=
        absl::StrFormat("; %d cells without data filled (%s)", ctx.out->stats.filled_terrain_cells,
                        o.terrain_fill.kind == FillRule::Kind::kNearest
                            ? "nearest cell with data"
                            : absl::StrFormat("%.9g m", o.terrain_fill.value));
  }
  ctx.out->inputs.push_back(
      {"terrain", o.terrain, in->driver, CrsShortName(in->srs.get()), CrsWkt(*in->srs), detail});
  return terrain;
}

}  // namespace riskplan::geo::internal
