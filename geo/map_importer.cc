#include "geo/map_importer.h"

#include <gdal.h>

#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "core/map/risk_map.h"
#include "geo/gdal_util.h"
#include "geo/import_steps.h"
#include "nlohmann/json.hpp"

namespace riskplan::geo {
namespace {

constexpr int kMaxThreads = 64;
constexpr double kMaxBufferM = 100'000.0;

absl::Status CheckRange(const char* flag, double v, double lo, double hi) {
  if (!(std::isfinite(v) && v >= lo && v <= hi)) {
    return absl::InvalidArgumentError(
        absl::StrFormat("--%s=%.9g: must be in [%g, %g]", flag, v, lo, hi));
  }
  return absl::OkStatus();
}

absl::Status ValidateOptions(const ImportOptions& o) {
  MapHeader probe;
  probe.name = o.name;
  probe.nx = probe.ny = 1;
  if (absl::Status s = ValidateMapHeader(probe); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("--name: ", s.message()));
  }
  if (o.terrain.empty()) {
    return absl::InvalidArgumentError("layer 'terrain': --terrain=DEM is required");
  }
  if (o.threads < 1 || o.threads > kMaxThreads) {
    return absl::InvalidArgumentError(
        absl::StrFormat("--threads=%d: must be in [1, %d]", o.threads, kMaxThreads));
  }
  for (auto [flag, v] :
       {std::pair{"base_shelter", o.base_shelter}, {"building_shelter", o.building_shelter}}) {
    if (absl::Status s = CheckRange(flag, v, 0.0, 10.0); !s.ok()) return s;
  }
  if (!(o.built_up_full_share > 0.0 && o.built_up_full_share <= 1.0)) {
    return absl::InvalidArgumentError(
        absl::StrFormat("--built_up_full_share=%.9g: must be in (0, 1]", o.built_up_full_share));
  }
  if (absl::Status s = CheckRange("nofly_buffer_m", o.nofly_buffer_m, 0.0, kMaxBufferM); !s.ok()) {
    return s;
  }
  if (absl::Status s = CheckRange("landing_min_area_m2", o.landing_min_area_m2, 0.0, 1e12);
      !s.ok()) {
    return s;
  }
  // A map holds at most 100,000 landing sites (kMaxLandingSites in import_zones.cc).
  if (o.max_landing_sites < 0 || o.max_landing_sites > 100'000) {
    return absl::InvalidArgumentError(
        absl::StrFormat("--max_landing_sites=%d: must be in [0, 100000]", o.max_landing_sites));
  }
  // A terrain fill must be a height the terrain step would accept from a
  // DEM (kLowestTerrainM..kHighestTerrainM in import_terrain.cc).
  if (o.terrain_fill.kind == FillRule::Kind::kValue) {
    if (absl::Status s = CheckRange("fill_terrain", o.terrain_fill.value, -500.0, 9000.0);
        !s.ok()) {
      return s;
    }
  }
  if (o.density_fill.kind == FillRule::Kind::kValue) {
    if (absl::Status s = CheckRange("fill_density", o.density_fill.value, 0.0, 1.0); !s.ok()) {
      return s;
    }
  }
  if (o.shelter_fill.kind == FillRule::Kind::kValue) {
    if (absl::Status s = CheckRange("fill_shelter", o.shelter_fill.value, 0.0, 10.0); !s.ok()) {
      return s;
    }
  }
  if (o.density_fill.kind == FillRule::Kind::kNearest ||
      o.shelter_fill.kind == FillRule::Kind::kNearest) {
    return absl::InvalidArgumentError(
        "--fill_density and --fill_shelter take a value ('nearest' is for the terrain only)");
  }
  return absl::OkStatus();
}

std::string FrameText(const TargetGrid& g) {
  return absl::StrFormat(
      "azimuthal equidistant on WGS84 centred at the map's south-west corner (%.9f, %.9f); %s",
      g.frame.origin_lat_deg(), g.frame.origin_lon_deg(), g.frame.proj_definition());
}

// Runs the layer steps in their order, noting each one's time.
absl::StatusOr<MapLayers> ImportLayers(internal::ImportContext& ctx) {
  std::vector<std::string> timings;
  absl::Time t = absl::Now();
  auto lap = [&](const char* step) {
    const absl::Time now = absl::Now();
    timings.push_back(absl::StrFormat("%s %.2f s", step, absl::ToDoubleSeconds(now - t)));
    t = now;
  };

  // Land cover before the shelter and the landing sites (both read it), and
  // no-fly before the landing sites (no site may lie in a no-fly cell).
  auto terrain = internal::ImportTerrain(ctx);
  if (!terrain.ok()) return terrain.status();
  lap("terrain");
  auto density = internal::ImportPopulation(ctx);
  if (!density.ok()) return density.status();
  lap("population");
  auto land_cover = internal::ImportLandCover(ctx);
  if (!land_cover.ok()) return land_cover.status();
  auto shelter = internal::ImportShelter(ctx, *land_cover);
  if (!shelter.ok()) return shelter.status();
  lap("shelter");
  auto nofly = internal::ImportNoFly(ctx);
  if (!nofly.ok()) return nofly.status();
  auto sites = internal::ImportLandingSites(ctx, *land_cover, *nofly);
  if (!sites.ok()) return sites.status();
  lap("no-fly and landing sites");
  ctx.Note(absl::StrCat("timings: ", absl::StrJoin(timings, ", ")));

  MapLayers layers;
  layers.terrain = *std::move(terrain);
  layers.density = *std::move(density);
  layers.shelter = *std::move(shelter);
  layers.nofly = *std::move(nofly);
  layers.landing_sites = *std::move(sites);
  return layers;
}

// The map's header: its grid, where it lies, and a one-line provenance.
MapHeader MakeHeader(const ImportOptions& options, const TargetGrid& g,
                     const std::vector<InputRecord>& inputs) {
  MapHeader header;
  header.name = options.name;
  header.x0 = g.frame.x0();
  header.y0 = g.frame.y0();
  header.res = g.res_m;
  header.nx = g.nx;
  header.ny = g.ny;
  GeoReference geo;
  geo.origin_lat_deg = g.frame.origin_lat_deg();
  geo.origin_lon_deg = g.frame.origin_lon_deg();
  geo.crs = FrameText(g);
  header.geo = geo;
  std::vector<std::string> described;
  for (const InputRecord& r : inputs) {
    described.push_back(absl::StrFormat("%s from '%s' (%s, %s)", r.layer, r.path, r.driver, r.crs));
  }
  header.provenance =
      absl::StrFormat("riskplan-tool import: %s; %d x %d cells of %.9g m; command: %s",
                      described.empty() ? "no inputs" : absl::StrJoin(described, "; "), g.nx, g.ny,
                      g.res_m, options.command_line);
  return header;
}

// The structured provenance of `out` (its inputs, notes and people) as JSON.
std::string ProvenanceJson(const ImportOptions& options, const TargetGrid& g,
                           const ImportedMap& out) {
  const LatLon centre = g.Center();
  nlohmann::json p;
  p["command"] = options.command_line;
  p["frame"] = {{"definition", g.frame.proj_definition()},
                {"origin_lat_deg", g.frame.origin_lat_deg()},
                {"origin_lon_deg", g.frame.origin_lon_deg()},
                {"centre_lat_deg", centre.lat_deg},
                {"centre_lon_deg", centre.lon_deg}};
  p["inputs"] = nlohmann::json::array();
  for (const InputRecord& r : out.inputs) {
    p["inputs"].push_back({{"layer", r.layer},
                           {"path", r.path},
                           {"driver", r.driver},
                           {"crs", r.crs},
                           {"crs_wkt", r.crs_wkt},
                           {"detail", r.detail}});
  }
  p["notes"] = out.notes;
  p["people_total"] = out.stats.people_total;
  p["gdal"] = GDALVersionInfo("RELEASE_NAME");
  // Paths, CRS names and the command line are bytes from the user's files
  // and shell, not always UTF-8 (a Latin-1 file name): replaced by U+FFFD
  // rather than letting the JSON library throw out of the import.
  return p.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace

absl::StatusOr<FillRule> ParseFillRule(const std::string& flag, const std::string& text,
                                       bool nearest_allowed) {
  FillRule rule;
  if (text.empty() || text == "none") return rule;
  if (text == "nearest") {
    if (!nearest_allowed) {
      return absl::InvalidArgumentError(
          absl::StrFormat("--%s=nearest: this layer takes a value or 'none'", flag));
    }
    rule.kind = FillRule::Kind::kNearest;
    return rule;
  }
  if (!absl::SimpleAtod(text, &rule.value) || !std::isfinite(rule.value)) {
    return absl::InvalidArgumentError(absl::StrFormat("--%s='%s': expected 'none', %sa number",
                                                      flag, text,
                                                      nearest_allowed ? "'nearest' or " : ""));
  }
  rule.kind = FillRule::Kind::kValue;
  return rule;
}

absl::StatusOr<VectorSpec> ParseVectorSpec(const std::string& text) {
  std::vector<std::string> parts = absl::StrSplit(text, '|');
  VectorSpec spec;
  spec.path = parts[0];
  if (spec.path.empty()) {
    return absl::InvalidArgumentError(
        absl::StrFormat("'%s': a vector input is PATH[|layername=NAME][|where=SQL]", text));
  }
  for (size_t k = 1; k < parts.size(); ++k) {
    std::vector<std::string> kv = absl::StrSplit(parts[k], absl::MaxSplits('=', 1));
    if (kv.size() == 2 && kv[0] == "layername") {
      spec.layer_name = kv[1];
    } else if (kv.size() == 2 && kv[0] == "where") {
      spec.where = kv[1];
    } else {
      return absl::InvalidArgumentError(absl::StrFormat(
          "'%s': unknown option '%s'; a vector input is PATH[|layername=NAME][|where=SQL]", text,
          parts[k]));
    }
  }
  return spec;
}

absl::StatusOr<ImportedMap> ImportMap(const ImportOptions& options) {
  if (absl::Status s = ValidateOptions(options); !s.ok()) return s;
  auto grid = MakeTargetGrid(options.area);
  if (!grid.ok()) return grid.status();
  EnsureGdalRegistered();
  auto frame_srs = SpatialReferenceFrom(grid->frame.proj_definition());
  if (!frame_srs.ok()) return frame_srs.status();

  ImportedMap out;
  internal::ImportContext ctx{options, *grid, *std::move(frame_srs), &out, std::nullopt};
  auto layers = ImportLayers(ctx);
  if (!layers.ok()) return layers.status();
  out.header = MakeHeader(options, ctx.grid, out.inputs);
  out.layers = *std::move(layers);
  out.provenance_json = ProvenanceJson(options, ctx.grid, out);
  return out;
}

}  // namespace riskplan::geo
