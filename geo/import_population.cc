// The population step: people per m^2 from a raster (people per pixel, or per
// km^2) or from census polygons with a count, spread over each polygon's
// area or over its built-up part.
#include <ogr_api.h>
#include <ogr_geometry.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_format.h"
#include "geo/grid_rasterize.h"
#include "geo/import_steps.h"
#include "geo/raster_input.h"
#include "geo/vector_input.h"

namespace riskplan::geo::internal {
namespace {

// Population rasters are warped onto blocks of cells a quarter of a pixel
// wide, of at most 16 x 16 cells (see WarpPopulation).
constexpr double kCellsPerPixelWidth = 4.0;
constexpr int kMaxBlock = 16;

// The people (or density) of a raster on the map's cells. A population raster
// holds nothing finer than its pixels (WorldPop's and GHSL's are 100 m), so
// when they are at least 4 cells wide it is warped onto blocks of k x k cells
// (k = pixel / (4 cells), at most 16) and each block's value is spread evenly
// over its cells: the same total, k^2 times less warping. A block the input
// leaves without data (at the input's edge) sends the warp back to single
// cells, so that a refusal names exactly the cells without data.
absl::StatusOr<std::vector<double>> WarpPopulation(const RasterInput& in, const TargetGrid& grid,
                                                   Resampling r, int threads, int* k_used) {
  auto pixel_m = PixelSizeNearMap(in, grid);
  if (!pixel_m.ok()) return pixel_m.status();
  const int k =
      static_cast<int>(std::clamp(std::floor(*pixel_m / (kCellsPerPixelWidth * grid.res_m)), 1.0,
                                  static_cast<double>(kMaxBlock)));
  *k_used = 1;
  if (k > 1) {
    TargetGrid blocks = grid;
    blocks.nx = (grid.nx + k - 1) / k;
    blocks.ny = (grid.ny + k - 1) / k;
    blocks.res_m = grid.res_m * k;
    auto coarse = WarpOntoGrid(in, blocks, r, threads);
    if (!coarse.ok()) return coarse.status();
    if (std::none_of(coarse->begin(), coarse->end(), [](double v) { return std::isnan(v); })) {
      // A sum is shared among the block's k^2 cells; a mean is every cell's.
      const double share = r == Resampling::kSum ? 1.0 / (k * k) : 1.0;
      std::vector<double> values(static_cast<size_t>(grid.cells()));
      for (int j = 0; j < grid.ny; ++j) {
        const double* row = coarse->data() + static_cast<size_t>(j / k) * blocks.nx;
        double* out = values.data() + static_cast<size_t>(j) * grid.nx;
        for (int i = 0; i < grid.nx; ++i) out[i] = row[i / k] * share;
      }
      *k_used = k;
      return values;
    }
  }
  return WarpOntoGrid(in, grid, r, threads);
}

absl::StatusOr<std::vector<double>> DensityFromRaster(ImportContext& ctx) {
  const ImportOptions& o = ctx.options;
  auto in = OpenRasterInput("population", o.population);
  if (!in.ok()) return in.status();
  const bool per_cell = o.population_unit == PopulationUnit::kPerCell;
  // People per pixel are a count: each cell takes the people of the part of
  // every pixel it covers (GDAL's 'sum'). People per km^2 are a density: the
  // area-weighted mean ('average'). Both keep the total.
  const Resampling r = per_cell ? Resampling::kSum : Resampling::kAverage;
  int k = 1;
  auto values = WarpPopulation(*in, ctx.grid, r, o.threads, &k);
  if (!values.ok()) return values.status();
  const double to_density = per_cell ? 1.0 / ctx.cell_area_m2() : 1e-6;
  for (size_t c = 0; c < values->size(); ++c) {
    double& v = (*values)[c];
    if (std::isnan(v)) continue;
    if (!(v >= 0.0) || !std::isfinite(v)) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "%s: cell (%d, %d) gets %.9g people %s; a population must be >= 0 and finite (an "
          "undeclared nodata value?)",
          in->Label(), static_cast<int>(c % ctx.grid.nx), static_cast<int>(c / ctx.grid.nx), v,
          per_cell ? "per cell" : "per km^2"));
    }
    v *= to_density;
  }
  std::vector<uint8_t> missing(values->size());
  bool any = false;
  for (size_t c = 0; c < values->size(); ++c) any |= (missing[c] = std::isnan((*values)[c]));
  int64_t filled = 0;
  if (any) {
    if (o.density_fill.kind == FillRule::Kind::kNone) {
      auto footprint = InputFootprint(*in, ctx.grid);
      if (!footprint.ok()) return footprint.status();
      for (uint8_t& f : *footprint) f = f == 0 ? 1 : 0;
      return MissingCellsError(ctx, in->Label(), in->srs.get(), missing, *footprint,
                               "--fill_density=PEOPLE_PER_M2 (e.g. 0 for the sea)");
    }
    filled = FillMissing(o.density_fill, ctx.grid.nx, ctx.grid.ny, &*values);
  }
  ctx.out->stats.filled_density_cells = filled;
  std::string detail = absl::StrFormat("%s; people %s, resampling %s", in->Summary(),
                                       per_cell ? "per pixel" : "per km^2", ResamplingName(r));
  if (k > 1) detail += absl::StrFormat(" onto blocks of %d x %d cells spread evenly", k, k);
  if (filled > 0) {
    detail += absl::StrFormat("; %d cells without data filled with %.9g people/m^2", filled,
                              o.density_fill.value);
  }
  ctx.out->inputs.push_back({"population", o.population, in->driver, CrsShortName(in->srs.get()),
                             CrsWkt(*in->srs), detail});
  return values;
}

// The census polygons that meet the map: each one's people, whole area (not
// only the part in the map) and geometry in the map's frame.
struct CensusPolygons {
  std::vector<double> people;
  std::vector<double> area_m2;
  std::vector<std::unique_ptr<OGRGeometry>> carried;
};

// Checks every feature (a polygon with a count >= 0 and an area) and carries
// it into an equal-area frame (for its area) and into the map's frame.
absl::StatusOr<CensusPolygons> CarryCensusPolygons(const VectorInput& in,
                                                   const std::vector<SourceFeature>& features,
                                                   const std::string& count_field,
                                                   const TargetGrid& grid) {
  auto to_frame = ToFrame(*in.srs, grid);
  if (!to_frame.ok()) return to_frame.status();
  auto equal_area = EqualAreaFrame(grid);
  if (!equal_area.ok()) return equal_area.status();
  auto to_equal_area = TransformationBetween(*in.srs, **equal_area);
  if (!to_equal_area.ok()) return to_equal_area.status();

  CensusPolygons out;
  CarryBudget budget;  // this input's
  for (const SourceFeature& f : features) {
    if (!IsPolygonal(*f.geometry)) {
      return absl::InvalidArgumentError(
          absl::StrFormat("%s: feature %d is a %s; census areas must be polygons", in.Label(),
                          f.fid, OGRGeometryTypeToName(f.geometry->getGeometryType())));
    }
    if (!f.number.has_value() || !std::isfinite(*f.number) || *f.number < 0.0) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "%s: feature %d has %s '%s'; a population count must be a number >= 0", in.Label(),
          f.fid, f.number.has_value() ? absl::StrFormat("%.9g in", *f.number) : "no value in",
          count_field));
    }
    auto ea = Carry(*f.geometry, *in.srs, **to_equal_area, budget);
    if (!ea.ok()) {
      return absl::InvalidArgumentError(
          absl::StrFormat("%s: feature %d: %s", in.Label(), f.fid, ea.status().message()));
    }
    const double area = OGR_G_Area(OGRGeometry::ToHandle(ea->get()));
    if (!(area > 0.0)) {
      return absl::InvalidArgumentError(
          absl::StrFormat("%s: feature %d has no area", in.Label(), f.fid));
    }
    auto g = Carry(*f.geometry, *in.srs, **to_frame, budget);
    if (!g.ok()) {
      return absl::InvalidArgumentError(
          absl::StrFormat("%s: feature %d: %s", in.Label(), f.fid, g.status().message()));
    }
    out.people.push_back(*f.number);
    out.area_m2.push_back(area);
    out.carried.push_back(*std::move(g));
  }
  return out;
}

// The polygon of each cell, numbered from 1 in the order of `polygons`
// (0: none).
absl::StatusOr<std::vector<int32_t>> BurnPolygonIds(const TargetGrid& grid,
                                                    const CensusPolygons& polygons) {
  std::vector<const OGRGeometry*> geometries;
  std::vector<int32_t> ids;
  for (size_t k = 0; k < polygons.carried.size(); ++k) {
    geometries.push_back(polygons.carried[k].get());
    ids.push_back(static_cast<int32_t>(k + 1));
  }
  return BurnIds(grid, geometries, ids);
}

// Each polygon's people spread evenly over its area (NaN outside every one).
std::vector<double> SpreadOverArea(const std::vector<int32_t>& id,
                                   const CensusPolygons& polygons) {
  std::vector<double> density(id.size(), std::nan(""));
  for (size_t c = 0; c < id.size(); ++c) {
    const int32_t v = id[c];
    if (v > 0) density[c] = polygons.people[v - 1] / polygons.area_m2[v - 1];
  }
  return density;
}

// The polygon's people in the map (its share of the polygon's area), spread
// over the built-up part of its cells in the map; a polygon without buildings
// in the map spreads over its area (counted in *no_buildings).
absl::StatusOr<std::vector<double>> SpreadOverBuiltUp(ImportContext& ctx,
                                                      const std::vector<int32_t>& id,
                                                      const CensusPolygons& polygons,
                                                      int* no_buildings) {
  const size_t n = polygons.carried.size();
  std::vector<int64_t> cells_of(n, 0);
  for (int32_t v : id) {
    if (v > 0) ++cells_of[v - 1];
  }
  auto share = BuiltUpShare(ctx);
  if (!share.ok()) return share.status();
  std::vector<double> built(n, 0.0);
  for (size_t c = 0; c < id.size(); ++c) {
    if (id[c] > 0) built[id[c] - 1] += (**share)[c];
  }
  *no_buildings = 0;
  for (size_t p = 0; p < n; ++p) *no_buildings += (cells_of[p] > 0 && built[p] == 0.0);
  std::vector<double> density(id.size(), std::nan(""));
  for (size_t c = 0; c < id.size(); ++c) {
    const int32_t v = id[c];
    if (v <= 0) continue;
    const size_t p = v - 1;
    if (built[p] > 0.0) {
      const double in_map =
          polygons.people[p] * cells_of[p] * ctx.cell_area_m2() / polygons.area_m2[p];
      density[c] = in_map * (**share)[c] / built[p] / ctx.cell_area_m2();
    } else {
      density[c] = polygons.people[p] / polygons.area_m2[p];
    }
  }
  return density;
}

absl::StatusOr<std::vector<double>> DensityFromPolygons(ImportContext& ctx) {
  const ImportOptions& o = ctx.options;
  auto spec = ParseVectorSpec(o.population);
  if (!spec.ok()) return spec.status();
  auto in = OpenVectorInput("population", spec->path, spec->layer_name, spec->where);
  if (!in.ok()) return in.status();
  auto features = ReadFeatures(*in, ctx.grid, 0.0, o.population_field, "");
  if (!features.ok()) return features.status();
  auto polygons = CarryCensusPolygons(*in, *features, o.population_field, ctx.grid);
  if (!polygons.ok()) return polygons.status();
  auto id = BurnPolygonIds(ctx.grid, *polygons);
  if (!id.ok()) return id.status();

  const size_t n = polygons->carried.size();
  std::vector<double> density;
  std::string spread = "spread over each polygon's area";
  if (o.buildings.empty()) {
    density = SpreadOverArea(*id, *polygons);
  } else {
    int no_buildings = 0;
    auto built_up = SpreadOverBuiltUp(ctx, *id, *polygons, &no_buildings);
    if (!built_up.ok()) return built_up.status();
    density = *std::move(built_up);
    spread = absl::StrFormat(
        "spread over the built-up part of each polygon in the map (the buildings input); %d "
        "polygons without buildings in the map spread over their area",
        no_buildings);
  }
  std::vector<uint8_t> missing(density.size());
  bool any = false;
  for (size_t c = 0; c < density.size(); ++c) any |= (missing[c] = std::isnan(density[c]));
  int64_t filled = 0;
  if (any) {
    if (o.density_fill.kind == FillRule::Kind::kNone) {
      return MissingCellsError(ctx, in->Label(), in->srs.get(), missing, {},
                               "--fill_density=PEOPLE_PER_M2 (e.g. 0)");
    }
    filled = FillMissing(o.density_fill, ctx.grid.nx, ctx.grid.ny, &density);
  }
  ctx.out->stats.filled_density_cells = filled;
  std::string detail = absl::StrFormat("%s; %d polygons meet the map; count field '%s'; %s",
                                       in->Summary(), n, o.population_field, spread);
  if (filled > 0) {
    detail += absl::StrFormat("; %d cells in no polygon filled with %.9g people/m^2", filled,
                              o.density_fill.value);
  }
  ctx.out->inputs.push_back({"population", spec->path, in->driver, CrsShortName(in->srs.get()),
                             CrsWkt(*in->srs), detail});
  return density;
}

}  // namespace

absl::StatusOr<std::vector<float>> ImportPopulation(ImportContext& ctx) {
  const ImportOptions& o = ctx.options;
  if (o.population.empty()) {
    ctx.Note("population: none given; density 0 everywhere");
    return std::vector<float>(static_cast<size_t>(ctx.grid.cells()), 0.0f);
  }
  auto density = o.population_field.empty() ? DensityFromRaster(ctx) : DensityFromPolygons(ctx);
  if (!density.ok()) return density.status();
  std::vector<float> out(density->size());
  double total = 0.0;
  for (size_t c = 0; c < out.size(); ++c) {
    out[c] = static_cast<float>((*density)[c]);
    total += static_cast<double>(out[c]) * ctx.cell_area_m2();
  }
  ctx.out->stats.people_total = total;
  return out;
}

}  // namespace riskplan::geo::internal
