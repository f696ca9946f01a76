// The no-fly and landing-site steps: polygons burnt into the grid, and the
// cells where an emergency landing is possible.
#include <ogr_api.h>
#include <ogr_geometry.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "geo/grid_rasterize.h"
#include "geo/grid_regions.h"
#include "geo/import_steps.h"
#include "geo/vector_input.h"

namespace riskplan::geo::internal {
namespace {

// Landing sites named in a note when they are dropped.
constexpr int kSitesNamed = 5;
// Every landing site of a map, however many the inputs hold (the manifest
// stays a few MB).
constexpr int kMaxLandingSites = 100'000;

bool IsPoint(const OGRGeometry& g) {
  const OGRwkbGeometryType t = wkbFlatten(g.getGeometryType());
  return t == wkbPoint || t == wkbMultiPoint;
}

// The cell of local point (x, y), or false outside the map.
bool CellOf(const TargetGrid& g, double x, double y, int* i, int* j) {
  const double fi = std::floor((x - g.frame.x0()) / g.res_m);
  const double fj = std::floor((y - g.frame.y0()) / g.res_m);
  if (!(fi >= 0 && fj >= 0 && fi < g.nx && fj < g.ny)) return false;
  *i = static_cast<int>(fi);
  *j = static_cast<int>(fj);
  return true;
}

std::string Stem(const std::string& path) { return std::filesystem::path(path).stem().string(); }

// The landing sites found so far, in the order found; a site in a no-fly cell
// is dropped and counted instead.
struct SiteCollector {
  const TargetGrid& grid;
  const std::vector<uint8_t>& nofly;
  ImportStats& stats;
  std::vector<LandingSite> sites;
  std::vector<std::string> dropped;  // the first kSitesNamed dropped, for the note

  void Offer(LandingSite site) {
    if (nofly[static_cast<size_t>(site.j) * grid.nx + site.i] != 0) {
      ++stats.landing_dropped_nofly;
      if (dropped.size() < kSitesNamed) dropped.push_back(site.name);
      return;
    }
    sites.push_back(std::move(site));
  }
};

// The polygons of every landing input, kept until all are read: they are
// labelled together, so that each gets its own cells.
struct LandingPolygons {
  std::vector<std::unique_ptr<OGRGeometry>> geometries;
  std::vector<std::string> names;
};

// Offers the cell under each point of `g` (a point or multipoint) as a site
// named `name`; returns how many lie in the map.
int OfferPoints(const OGRGeometry& g, const std::string& name, SiteCollector& collector) {
  std::vector<const OGRPoint*> pts;
  if (wkbFlatten(g.getGeometryType()) == wkbPoint) {
    pts.push_back(g.toPoint());
  } else {
    for (const OGRPoint* p : *g.toMultiPoint()) pts.push_back(p);
  }
  int points = 0;
  for (const OGRPoint* p : pts) {
    int i = 0, j = 0;
    if (!CellOf(collector.grid, p->getX(), p->getY(), &i, &j)) {
      ++collector.stats.landing_outside_map;
      continue;
    }
    ++points;
    collector.Offer({name, i, j});
  }
  return points;
}

// Reads one --landing input: its points become sites at once, its polygons
// are added to `polygons`; records the input.
absl::Status ReadLandingInput(ImportContext& ctx, const std::string& text, SiteCollector& collector,
                              LandingPolygons& polygons) {
  const ImportOptions& o = ctx.options;
  auto spec = ParseVectorSpec(text);
  if (!spec.ok()) return spec.status();
  auto in = OpenVectorInput("landing sites", spec->path, spec->layer_name, spec->where);
  if (!in.ok()) return in.status();
  auto features = ReadFeatures(*in, ctx.grid, 0.0, "", o.landing_name_field);
  if (!features.ok()) return features.status();
  auto ct = ToFrame(*in->srs, ctx.grid);
  if (!ct.ok()) return ct.status();
  int points = 0, areas = 0;
  CarryBudget budget;  // this input's
  for (const SourceFeature& f : *features) {
    const std::string name =
        f.text.empty() ? absl::StrFormat("%s-%d", Stem(spec->path), f.fid) : f.text;
    auto g = Carry(*f.geometry, *in->srs, **ct, budget);
    if (!g.ok()) {
      return absl::InvalidArgumentError(
          absl::StrFormat("%s: feature %d: %s", in->Label(), f.fid, g.status().message()));
    }
    if (IsPoint(**g)) {
      points += OfferPoints(**g, name, collector);
    } else if (IsPolygonal(**g)) {
      ++areas;
      polygons.geometries.push_back(*std::move(g));
      polygons.names.push_back(name);
    } else {
      return absl::InvalidArgumentError(absl::StrFormat(
          "%s: feature %d is a %s; landing sites are points or polygons", in->Label(), f.fid,
          OGRGeometryTypeToName(f.geometry->getGeometryType())));
    }
  }
  ctx.out->inputs.push_back(
      {"landing sites", spec->path, in->driver, CrsShortName(in->srs.get()), CrsWkt(*in->srs),
       absl::StrFormat("%s; %d points and %d polygons meet the map%s", in->Summary(), points, areas,
                       o.landing_name_field.empty()
                           ? ""
                           : absl::StrFormat("; names from '%s'", o.landing_name_field))});
  return absl::OkStatus();
}

// Offers a site for each polygon: the cell deepest inside it, or, when it
// holds no cell of its own, the cell of a point on its surface.
absl::Status OfferPolygonSites(const LandingPolygons& polygons, SiteCollector& collector) {
  const TargetGrid& grid = collector.grid;
  const size_t count = polygons.geometries.size();
  std::vector<const OGRGeometry*> geometries;
  std::vector<int32_t> ids;
  for (size_t k = 0; k < count; ++k) {
    geometries.push_back(polygons.geometries[k].get());
    ids.push_back(static_cast<int32_t>(k + 1));
  }
  auto labels = BurnIds(grid, geometries, ids);
  if (!labels.ok()) return labels.status();
  // No-fly cells are outside every field: the deepest cell keeps away from them.
  for (size_t c = 0; c < labels->size(); ++c) {
    if (collector.nofly[c] != 0) (*labels)[c] = 0;
  }
  std::vector<uint8_t> placed(count, 0);
  for (const Region& r : Regions(*labels, static_cast<int32_t>(count), grid.nx, grid.ny, {})) {
    placed[r.label - 1] = 1;
    collector.Offer({polygons.names[r.label - 1], r.deepest_i, r.deepest_j});
  }
  for (size_t k = 0; k < count; ++k) {
    if (placed[k]) continue;
    // Smaller than a cell, wholly in no-fly cells, or outside the map: the
    // cell of a point on its surface, if the map holds it.
    OGRGeometryH point = OGR_G_PointOnSurface(OGRGeometry::ToHandle(polygons.geometries[k].get()));
    int i = 0, j = 0;
    const bool inside =
        point != nullptr && CellOf(grid, OGR_G_GetX(point, 0), OGR_G_GetY(point, 0), &i, &j);
    if (point != nullptr) OGR_G_DestroyGeometry(point);
    if (inside) {
      collector.Offer({polygons.names[k], i, j});
    } else {
      ++collector.stats.landing_outside_map;
    }
  }
  return absl::OkStatus();
}

// Adds a site at the deepest cell of each open field of the land cover
// (--landing_min_area_m2): the largest fields first, at most
// --max_landing_sites of them.
absl::Status AddOpenFields(ImportContext& ctx, const std::optional<LandCover>& land_cover,
                           const std::vector<uint8_t>& nofly, std::vector<LandingSite>& sites) {
  const ImportOptions& o = ctx.options;
  const TargetGrid& grid = ctx.grid;
  if (!land_cover.has_value()) {
    return absl::InvalidArgumentError(
        "layer 'landing sites': open fields (--landing_min_area_m2) are found in the land "
        "cover; give --landcover");
  }
  std::vector<uint8_t> open(static_cast<size_t>(grid.cells()), 0);
  ClassRules rules(land_cover->table);
  for (size_t c = 0; c < open.size(); ++c) {
    const double v = land_cover->classes[c];
    if (std::isnan(v) || nofly[c] != 0) continue;
    open[c] = rules.Find(v)->landing ? 1 : 0;
  }
  int32_t count = 0;
  const std::vector<int32_t> labels = LabelComponents(open, grid.nx, grid.ny, &count);
  std::vector<Region> fields = Regions(labels, count, grid.nx, grid.ny, {});
  // The 1e-9 keeps an area that is a whole number of cells from rounding up
  // to one cell more.
  const int64_t min_cells =
      static_cast<int64_t>(std::ceil(o.landing_min_area_m2 / ctx.cell_area_m2() - 1e-9));
  std::erase_if(fields, [&](const Region& r) { return r.cells < min_cells; });
  // Stable: fields of equal size keep their labelling order, so which are
  // kept and their field-N names do not depend on the sort's implementation.
  std::stable_sort(fields.begin(), fields.end(),
                   [](const Region& a, const Region& b) { return a.cells > b.cells; });
  const size_t kept = std::min(fields.size(), static_cast<size_t>(o.max_landing_sites));
  for (size_t k = 0; k < kept; ++k) {
    sites.push_back({absl::StrFormat("field-%d", k + 1), fields[k].deepest_i, fields[k].deepest_j});
  }
  ctx.out->stats.landing_from_landcover = static_cast<int>(kept);
  ctx.Note(absl::StrFormat(
      "landing sites: %d open fields of at least %.9g m^2 in the land cover ('landing' "
      "classes, no-fly cells excluded), %d kept (the largest first), each at its cell deepest "
      "inside the field",
      fields.size(), o.landing_min_area_m2, kept));
  return absl::OkStatus();
}

// Keeps one site per cell (the first named), then refuses more than
// kMaxLandingSites.
absl::Status KeepOneSitePerCell(std::vector<LandingSite>& sites) {
  std::set<std::pair<int, int>> seen;
  std::erase_if(sites, [&](const LandingSite& s) { return !seen.insert({s.i, s.j}).second; });
  if (sites.size() > static_cast<size_t>(kMaxLandingSites)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "layer 'landing sites': %d sites; a map holds at most %d", sites.size(), kMaxLandingSites));
  }
  return absl::OkStatus();
}

// Notes the sites dropped in no-fly cells (naming the first few) and those
// outside the map.
void NoteLeftOutSites(ImportContext& ctx, const std::vector<std::string>& dropped) {
  const ImportStats& stats = ctx.out->stats;
  if (stats.landing_dropped_nofly > 0) {
    ctx.Note(absl::StrFormat("landing sites: %d inside no-fly cells dropped (%s%s)",
                             stats.landing_dropped_nofly, absl::StrJoin(dropped, ", "),
                             stats.landing_dropped_nofly > kSitesNamed ? ", ..." : ""));
  }
  if (stats.landing_outside_map > 0) {
    ctx.Note(
        absl::StrFormat("landing sites: %d outside the map left out", stats.landing_outside_map));
  }
}

}  // namespace

absl::StatusOr<std::vector<uint8_t>> ImportNoFly(ImportContext& ctx) {
  const ImportOptions& o = ctx.options;
  const double buffer = o.nofly_buffer_m;
  std::vector<std::unique_ptr<OGRGeometry>> zones;
  for (const std::string& text : o.nofly) {
    auto spec = ParseVectorSpec(text);
    if (!spec.ok()) return spec.status();
    auto in = OpenVectorInput("no-fly", spec->path, spec->layer_name, spec->where);
    if (!in.ok()) return in.status();
    // A zone just outside the map reaches into it once buffered.
    auto features = ReadFeatures(*in, ctx.grid, buffer, "", "");
    if (!features.ok()) return features.status();
    auto ct = ToFrame(*in->srs, ctx.grid);
    if (!ct.ok()) return ct.status();
    CarryBudget budget;  // this input's
    for (const SourceFeature& f : *features) {
      if (buffer == 0.0 && !IsPolygonal(*f.geometry)) {
        return absl::InvalidArgumentError(absl::StrFormat(
            "%s: feature %d is a %s, which encloses no area; give --nofly_buffer_m to make a "
            "zone around it",
            in->Label(), f.fid, OGRGeometryTypeToName(f.geometry->getGeometryType())));
      }
      auto g = Carry(*f.geometry, *in->srs, **ct, budget);
      if (!g.ok()) {
        return absl::InvalidArgumentError(
            absl::StrFormat("%s: feature %d: %s", in->Label(), f.fid, g.status().message()));
      }
      if (buffer > 0.0) {
        // GEOS's buffer in the local frame's metres, 8 segments a quarter circle.
        GdalErrorCapture errors;
        std::unique_ptr<OGRGeometry> grown((*g)->Buffer(buffer, 8));
        if (grown == nullptr) {
          return absl::InvalidArgumentError(absl::StrFormat("%s: feature %d cannot be buffered: %s",
                                                            in->Label(), f.fid, errors.Errors()));
        }
        zones.push_back(std::move(grown));
      } else {
        zones.push_back(*std::move(g));
      }
    }
    ctx.out->inputs.push_back(
        {"no-fly", spec->path, in->driver, CrsShortName(in->srs.get()), CrsWkt(*in->srs),
         absl::StrFormat("%s; %d features meet the map%s; every cell a zone touches is no-fly",
                         in->Summary(), features->size(),
                         buffer > 0.0 ? absl::StrFormat(", buffered by %.9g m", buffer) : "")});
  }
  std::vector<const OGRGeometry*> geometries;
  for (const auto& z : zones) geometries.push_back(z.get());
  auto mask = BurnMask(ctx.grid, geometries, /*all_touched=*/true);
  if (!mask.ok()) return mask.status();
  int64_t n = 0;
  for (uint8_t v : *mask) n += v;
  ctx.out->stats.nofly_cells = n;
  return mask;
}

absl::StatusOr<std::vector<LandingSite>> ImportLandingSites(
    ImportContext& ctx, const std::optional<LandCover>& land_cover,
    const std::vector<uint8_t>& nofly) {
  SiteCollector collector{ctx.grid, nofly, ctx.out->stats, {}, {}};
  LandingPolygons polygons;
  for (const std::string& text : ctx.options.landing) {
    if (absl::Status s = ReadLandingInput(ctx, text, collector, polygons); !s.ok()) return s;
  }
  // Polygons of every input, labelled together: the cell deepest inside each.
  if (!polygons.geometries.empty()) {
    if (absl::Status s = OfferPolygonSites(polygons, collector); !s.ok()) return s;
  }
  std::vector<LandingSite>& sites = collector.sites;
  ctx.out->stats.landing_from_inputs = static_cast<int>(sites.size());
  // Open fields are found with the no-fly cells already taken out, so they
  // are not offered (none can be dropped).
  if (ctx.options.landing_min_area_m2 > 0.0) {
    if (absl::Status s = AddOpenFields(ctx, land_cover, nofly, sites); !s.ok()) return s;
  }
  if (absl::Status s = KeepOneSitePerCell(sites); !s.ok()) return s;
  NoteLeftOutSites(ctx, collector.dropped);
  return std::move(sites);
}

}  // namespace riskplan::geo::internal
