// The shelter step: land-cover classes read through a class table, raised
// where buildings cover the cell.
#include <ogr_geometry.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "geo/grid_rasterize.h"
#include "geo/import_steps.h"
#include "geo/raster_input.h"
#include "geo/vector_input.h"

namespace riskplan::geo::internal {
namespace {

// Buildings are sampled on up to 4 x 4 sub-cells of each cell, with at most
// this many sub-cells in all (64 MiB of bytes).
constexpr int kMaxSubcellsPerSide = 4;
constexpr int64_t kMaxSubcells = int64_t{64} * 1024 * 1024;
// Classes named in a refusal for having no rule.
constexpr int kClassesNamed = 8;

}  // namespace

bool IsPolygonal(const OGRGeometry& g) {
  const OGRwkbGeometryType t = wkbFlatten(g.getGeometryType());
  return t == wkbPolygon || t == wkbMultiPolygon || t == wkbCurvePolygon || t == wkbMultiSurface;
}

absl::StatusOr<const std::vector<float>*> BuiltUpShare(ImportContext& ctx) {
  if (ctx.built_up.has_value()) return &*ctx.built_up;
  auto spec = ParseVectorSpec(ctx.options.buildings);
  if (!spec.ok()) return spec.status();
  auto in = OpenVectorInput("buildings", spec->path, spec->layer_name, spec->where);
  if (!in.ok()) return in.status();
  if (spec->where.empty() && in->driver == "OSM") {
    // An OpenStreetMap file's multipolygons are every area: keep the buildings.
    in->where = "building IS NOT NULL";
    in->ogr_layer->SetAttributeFilter(in->where.c_str());
  }
  auto features = ReadFeatures(*in, ctx.grid, 0.0, "", "");
  if (!features.ok()) return features.status();
  auto ct = ToFrame(*in->srs, ctx.grid);
  if (!ct.ok()) return ct.status();
  std::vector<std::unique_ptr<OGRGeometry>> carried;
  int64_t not_polygons = 0;
  CarryBudget budget;  // this input's
  for (const SourceFeature& f : *features) {
    if (!IsPolygonal(*f.geometry)) {
      ++not_polygons;
      continue;
    }
    auto g = Carry(*f.geometry, *in->srs, **ct, budget);
    if (!g.ok()) {
      return absl::InvalidArgumentError(
          absl::StrFormat("%s: feature %d: %s", in->Label(), f.fid, g.status().message()));
    }
    carried.push_back(*std::move(g));
  }
  std::vector<const OGRGeometry*> geometries;
  for (const auto& g : carried) geometries.push_back(g.get());
  int k = 1;
  auto share = CoverageShare(ctx.grid, geometries, kMaxSubcellsPerSide, kMaxSubcells, &k);
  if (!share.ok()) {
    return absl::Status(share.status().code(),
                        absl::StrCat(in->Label(), ": ", share.status().message()));
  }
  double covered = 0.0;
  for (float s : *share) covered += s;
  ctx.out->inputs.push_back(
      {"buildings", spec->path, in->driver, CrsShortName(in->srs.get()), CrsWkt(*in->srs),
       absl::StrFormat("%s; %d footprints meet the map (%d features that are not polygons left "
                       "out); built-up share on %d x %d sub-cells per cell; %.2f %% of the map "
                       "built up",
                       in->Summary(), carried.size(), not_polygons, k, k,
                       100.0 * covered / static_cast<double>(ctx.grid.cells()))});
  ctx.built_up = *std::move(share);
  return &*ctx.built_up;
}

absl::StatusOr<std::optional<LandCover>> ImportLandCover(ImportContext& ctx) {
  const ImportOptions& o = ctx.options;
  if (o.landcover.empty()) return std::optional<LandCover>();
  LandCover lc;
  auto table = DefaultShelterTable(o.landcover_classes);
  if (!table.ok()) return table.status();
  lc.table = *std::move(table);
  if (!o.shelter_table_file.empty()) {
    if (absl::Status s = ApplyShelterFile(o.shelter_table_file, &lc.table); !s.ok()) return s;
  }
  auto in = OpenRasterInput("land cover", o.landcover);
  if (!in.ok()) return in.status();
  auto pixel_m = PixelSizeNearMap(*in, ctx.grid);
  if (!pixel_m.ok()) return pixel_m.status();
  // Classes are never averaged: the class under the cell's centre when the
  // pixels are at least as large as the cells, else the most frequent one.
  // The 0.999 leaves room for the rounding of the pixel size measured at the
  // map.
  const Resampling r =
      *pixel_m >= 0.999 * ctx.grid.res_m ? Resampling::kNearest : Resampling::kMode;
  auto classes = WarpOntoGrid(*in, ctx.grid, r, o.threads);
  if (!classes.ok()) return classes.status();
  std::map<int64_t, int64_t> unknown;
  std::vector<uint8_t> missing(classes->size());
  bool any_missing = false;
  for (size_t c = 0; c < classes->size(); ++c) {
    const double v = (*classes)[c];
    if (std::isnan(v)) {
      missing[c] = 1;
      any_missing = true;
      continue;
    }
    // Beyond 2e9 a class would not fit the table's int.
    if (v != std::floor(v) || std::abs(v) > 2e9) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "%s: cell (%d, %d) has class %.9g; land-cover classes must be integers", in->Label(),
          static_cast<int>(c % ctx.grid.nx), static_cast<int>(c / ctx.grid.nx), v));
    }
    if (!lc.table.rules.contains(static_cast<int>(v))) ++unknown[static_cast<int64_t>(v)];
  }
  if (!unknown.empty()) {
    std::vector<std::string> named;
    for (const auto& [cls, n] : unknown) {
      if (named.size() == kClassesNamed) break;
      named.push_back(absl::StrFormat("%d (%d cells)", cls, n));
    }
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s: %d classes have no rule in the '%s' table: %s%s; give them shelter factors in a "
        "file (--shelter_table), or choose --landcover_classes",
        in->Label(), unknown.size(), lc.table.name, absl::StrJoin(named, ", "),
        unknown.size() > named.size() ? ", ..." : ""));
  }
  int64_t filled = 0;
  if (any_missing) {
    if (o.shelter_fill.kind == FillRule::Kind::kNone) {
      auto footprint = InputFootprint(*in, ctx.grid);
      if (!footprint.ok()) return footprint.status();
      for (uint8_t& f : *footprint) f = f == 0 ? 1 : 0;
      return MissingCellsError(ctx, in->Label(), in->srs.get(), missing, *footprint,
                               "--fill_shelter=SHELTER");
    }
    for (uint8_t m : missing) filled += m;
  }
  ctx.out->stats.filled_shelter_cells = filled;
  std::string detail =
      absl::StrFormat("%s; classes '%s'; pixels about %.3g m at the map, resampling %s",
                      in->Summary(), lc.table.name, *pixel_m, ResamplingName(r));
  if (filled > 0) {
    detail += absl::StrFormat("; %d cells without a class get shelter %.9g", filled,
                              o.shelter_fill.value);
  }
  ctx.out->inputs.push_back({"land cover", o.landcover, in->driver, CrsShortName(in->srs.get()),
                             CrsWkt(*in->srs), detail});
  lc.classes = *std::move(classes);
  return std::optional<LandCover>(std::move(lc));
}

absl::StatusOr<std::vector<float>> ImportShelter(ImportContext& ctx,
                                                 const std::optional<LandCover>& land_cover) {
  const ImportOptions& o = ctx.options;
  std::vector<float> shelter(static_cast<size_t>(ctx.grid.cells()),
                             static_cast<float>(o.base_shelter));
  if (land_cover.has_value()) {
    for (size_t c = 0; c < shelter.size(); ++c) {
      const double v = land_cover->classes[c];
      shelter[c] =
          std::isnan(v)
              ? static_cast<float>(o.shelter_fill.value)
              : static_cast<float>(land_cover->table.rules.at(static_cast<int>(v)).shelter);
    }
  } else {
    ctx.Note(
        absl::StrFormat("shelter: no land cover; %.9g where no building stands", o.base_shelter));
  }
  if (!o.buildings.empty()) {
    auto share = BuiltUpShare(ctx);
    if (!share.ok()) return share.status();
    // A cell's shelter rises from its ground's towards building_shelter as
    // roofs cover it, reaching it at built_up_full_share (the streets and
    // yards between houses are sheltered by them too); buildings never lower
    // it.
    const double full = o.built_up_full_share;
    for (size_t c = 0; c < shelter.size(); ++c) {
      const double ground = shelter[c];
      const double t = std::min(1.0, static_cast<double>((**share)[c]) / full);
      shelter[c] = static_cast<float>(std::max(ground, ground + (o.building_shelter - ground) * t));
    }
  }
  double sum = 0.0;
  for (float s : shelter) sum += s;
  ctx.out->stats.shelter_mean = sum / static_cast<double>(shelter.size());
  return shelter;
}

}  // namespace riskplan::geo::internal
