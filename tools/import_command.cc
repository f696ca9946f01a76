#include "tools/import_command.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "absl/flags/declare.h"
#include "absl/flags/flag.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "core/map/map_bundle.h"
#include "core/map/risk_map.h"
#include "geo/map_importer.h"

ABSL_DECLARE_FLAG(std::string, out);
ABSL_DECLARE_FLAG(double, size_m);
ABSL_DECLARE_FLAG(double, res_m);
ABSL_DECLARE_FLAG(int, threads);

ABSL_FLAG(std::string, name, "",
          "import: the map's name ([a-z0-9._-], 1 to 64 characters); empty: from --out's last "
          "folder");
ABSL_FLAG(std::string, center, "",
          "import: the area's centre 'LAT,LON' in WGS84 degrees (latitude first), with --size_m "
          "(and --height_m)");
ABSL_FLAG(double, height_m, 0.0, "import: the area's north-south size; 0: --size_m (a square)");
ABSL_FLAG(std::string, bbox, "",
          "import: the area as 'WEST,SOUTH,EAST,NORTH' in WGS84 degrees (longitude first, as "
          "gdalwarp -te and OpenStreetMap write it), instead of --center");
ABSL_FLAG(std::string, terrain, "",
          "import: the DEM raster, m above mean sea level (GeoTIFF, SRTM .hgt, ...; required)");
ABSL_FLAG(std::string, fill_terrain, "none",
          "import: cells the DEM leaves without data: 'none' (refuse), 'nearest' (the nearest "
          "cell with data) or metres");
ABSL_FLAG(std::string, population, "",
          "import: a population raster, or census polygons (PATH[|layername=L][|where=SQL]) "
          "with --population_field");
ABSL_FLAG(std::string, population_unit, "per_cell",
          "import: a population raster's values: 'per_cell' (people per pixel: WorldPop, GHSL "
          "POP) or 'per_km2' (people per square kilometre)");
ABSL_FLAG(std::string, population_field, "",
          "import: the census polygons' count attribute (e.g. POP); set: --population is "
          "polygons");
ABSL_FLAG(std::string, fill_density, "none",
          "import: cells the population leaves without data: 'none' (refuse) or people per m^2 "
          "(e.g. 0)");
ABSL_FLAG(std::string, landcover, "", "import: a land-cover raster of classes (shelter, fields)");
ABSL_FLAG(std::string, landcover_classes, "worldcover",
          "import: the land cover's classes: 'worldcover' (ESA WorldCover) or 'corine' (CORINE "
          "Land Cover)");
ABSL_FLAG(std::string, shelter_table, "",
          "import: a file of 'CLASS SHELTER [landing]' lines applied over the class table");
ABSL_FLAG(std::string, buildings, "",
          "import: building footprints (PATH[|layername=L][|where=SQL]; an OpenStreetMap "
          ".osm/.pbf file: its buildings)");
ABSL_FLAG(double, base_shelter, 2.5, "import: shelter where no land cover is given, [0, 10]");
ABSL_FLAG(double, building_shelter, 7.5, "import: shelter of a cell fully built up, [0, 10]");
ABSL_FLAG(double, built_up_full_share, 0.5,
          "import: the share of a cell under roofs from which it counts as fully built up");
ABSL_FLAG(std::string, fill_shelter, "none",
          "import: cells the land cover leaves without a class: 'none' (refuse) or a shelter "
          "factor");
ABSL_FLAG(std::string, nofly, "",
          "import: no-fly zones, comma-separated vector inputs (PATH[|layername=L][|where=SQL])");
ABSL_FLAG(double, nofly_buffer_m, 0.0, "import: grow every no-fly zone by this many metres");
ABSL_FLAG(std::string, landing, "",
          "import: landing sites, comma-separated vector inputs of points (the cell under each) "
          "or polygons (the cell deepest inside)");
ABSL_FLAG(std::string, landing_name_field, "", "import: the landing sites' name attribute");
ABSL_FLAG(double, landing_min_area_m2, 0.0,
          "import: also make a landing site of every open field of the land cover at least "
          "this large (0: none)");
ABSL_FLAG(int, max_landing_sites, 1000, "import: open fields kept as landing sites, largest first");

namespace riskplan {
namespace {

// Exit code 2 for bad input (InvalidArgument), 1 for any other failure: the
// codes riskplan-tool's help promises for every command.
int Fail(const absl::Status& status) {
  std::fprintf(stderr, "riskplan-tool: %s\n", std::string(status.message()).c_str());
  return status.code() == absl::StatusCode::kInvalidArgument ? 2 : 1;
}

absl::StatusOr<std::vector<double>> Numbers(const char* flag, const std::string& text, size_t n) {
  std::vector<double> values;
  for (absl::string_view part : absl::StrSplit(text, ',')) {
    double v = 0.0;
    if (!absl::SimpleAtod(absl::StripAsciiWhitespace(part), &v) || !std::isfinite(v)) {
      values.clear();
      break;
    }
    values.push_back(v);
  }
  if (values.size() != n) {
    return absl::InvalidArgumentError(
        absl::StrFormat("--%s='%s': expected %d comma-separated numbers", flag, text, n));
  }
  return values;
}

// Empty items (a trailing comma, ",,") are skipped, not read as inputs
// named "".
std::vector<std::string> List(const std::string& text) {
  return absl::StrSplit(text, ',', absl::SkipWhitespace());
}

// A map name from a directory: lower case, other characters as '-'.
std::string NameFromDirectory(const std::string& dir) {
  std::string leaf = std::filesystem::path(dir).lexically_normal().filename().string();
  // "maps/city/" has an empty last part: the folder before the separator.
  if (leaf.empty()) leaf = std::filesystem::path(dir).lexically_normal().parent_path().filename();
  std::string name;
  for (char c : absl::AsciiStrToLower(leaf)) {
    const bool ok = absl::ascii_isalnum(c) || c == '.' || c == '_' || c == '-';
    name.push_back(ok ? c : '-');
  }
  return name.substr(0, 64);  // a map name has at most 64 characters
}

// The command line as the provenance records it: each word that a shell
// would split or expand single-quoted, so that the import can be run again
// from the manifest.
std::string CommandLine(int argc, char** argv) {
  std::vector<std::string> words;
  for (int k = 0; k < argc; ++k) {
    std::string w = argv[k];
    if (w.find_first_of(" \t'\"|;&$`\\*?()<>") != std::string::npos) {
      std::string quoted = "'";
      for (char c : w) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
      w = quoted + "'";
    }
    words.push_back(w);
  }
  return absl::StrJoin(words, " ");
}

absl::StatusOr<geo::ImportOptions> OptionsFromFlags(int argc, char** argv) {
  geo::ImportOptions o;
  const std::string out = absl::GetFlag(FLAGS_out);
  if (out.empty()) return absl::InvalidArgumentError("import: --out=DIR is required");
  o.name = absl::GetFlag(FLAGS_name);
  if (o.name.empty()) o.name = NameFromDirectory(out);
  o.command_line = CommandLine(argc, argv);
  o.threads = absl::GetFlag(FLAGS_threads);

  o.area.res_m = absl::GetFlag(FLAGS_res_m);
  const std::string center = absl::GetFlag(FLAGS_center);
  const std::string bbox = absl::GetFlag(FLAGS_bbox);
  if (center.empty() == bbox.empty()) {
    return absl::InvalidArgumentError(
        "import: give the area as --center=LAT,LON with --size_m, or as --bbox=W,S,E,N");
  }
  if (!center.empty()) {
    auto v = Numbers("center", center, 2);
    if (!v.ok()) return v.status();
    o.area.center = geo::LatLon{(*v)[0], (*v)[1]};
    o.area.width_m = absl::GetFlag(FLAGS_size_m);
    const double h = absl::GetFlag(FLAGS_height_m);
    o.area.height_m = h > 0.0 ? h : o.area.width_m;
  } else {
    auto v = Numbers("bbox", bbox, 4);
    if (!v.ok()) return v.status();
    o.area.bbox = geo::LonLatBox{(*v)[0], (*v)[1], (*v)[2], (*v)[3]};
  }

  o.terrain = absl::GetFlag(FLAGS_terrain);
  auto fill = geo::ParseFillRule("fill_terrain", absl::GetFlag(FLAGS_fill_terrain), true);
  if (!fill.ok()) return fill.status();
  o.terrain_fill = *fill;

  o.population = absl::GetFlag(FLAGS_population);
  const std::string unit = absl::GetFlag(FLAGS_population_unit);
  if (unit == "per_cell") {
    o.population_unit = geo::PopulationUnit::kPerCell;
  } else if (unit == "per_km2") {
    o.population_unit = geo::PopulationUnit::kPerKm2;
  } else {
    return absl::InvalidArgumentError(
        absl::StrFormat("--population_unit='%s': expected 'per_cell' or 'per_km2'", unit));
  }
  o.population_field = absl::GetFlag(FLAGS_population_field);
  fill = geo::ParseFillRule("fill_density", absl::GetFlag(FLAGS_fill_density), false);
  if (!fill.ok()) return fill.status();
  o.density_fill = *fill;

  o.landcover = absl::GetFlag(FLAGS_landcover);
  o.landcover_classes = absl::GetFlag(FLAGS_landcover_classes);
  o.shelter_table_file = absl::GetFlag(FLAGS_shelter_table);
  o.buildings = absl::GetFlag(FLAGS_buildings);
  o.base_shelter = absl::GetFlag(FLAGS_base_shelter);
  o.building_shelter = absl::GetFlag(FLAGS_building_shelter);
  o.built_up_full_share = absl::GetFlag(FLAGS_built_up_full_share);
  fill = geo::ParseFillRule("fill_shelter", absl::GetFlag(FLAGS_fill_shelter), false);
  if (!fill.ok()) return fill.status();
  o.shelter_fill = *fill;

  o.nofly = List(absl::GetFlag(FLAGS_nofly));
  o.nofly_buffer_m = absl::GetFlag(FLAGS_nofly_buffer_m);
  o.landing = List(absl::GetFlag(FLAGS_landing));
  o.landing_name_field = absl::GetFlag(FLAGS_landing_name_field);
  o.landing_min_area_m2 = absl::GetFlag(FLAGS_landing_min_area_m2);
  o.max_landing_sites = absl::GetFlag(FLAGS_max_landing_sites);
  return o;
}

}  // namespace

cmdline::CommandHelp ImportCommandHelp() {
  return {
      "import",
      "build a map bundle from real geodata (DEM, population, land cover, buildings, no-fly, "
      "landing sites; any CRS GDAL reads)",
      "  riskplan-tool import --out=DIR (--center=LAT,LON --size_m=M [--height_m=M] |\n"
      "                       --bbox=W,S,E,N) [--res_m=5] --terrain=DEM [--fill_terrain=...]\n"
      "                       [--population=RASTER [--population_unit=per_cell|per_km2] |\n"
      "                        --population=POLYGONS --population_field=F] [--fill_density=..]\n"
      "                       [--landcover=RASTER [--landcover_classes=worldcover|corine]\n"
      "                        [--shelter_table=F]] [--buildings=VECTOR]\n"
      "                       [--nofly=V,... [--nofly_buffer_m=M]] [--landing=V,...]\n"
      "                       [--landing_min_area_m2=A] [--name=N] [--threads=N]\n"
      "\n"
      "Warps every raster with GDAL into the map's local frame (azimuthal equidistant\n"
      "centred at its south-west corner; rows south to north) and burns every vector\n"
      "into its cells. A vector input is PATH[|layername=NAME][|where=SQL]. Inputs\n"
      "that do not cover the map are refused, naming the uncovered extent, unless a\n"
      "--fill_* flag says what to put there. docs/geodata.md has the rules and a\n"
      "walk-through for a city of your own.\n"
      "\n"
      "Example (Luxembourg city, 8 km x 8 km at 10 m):\n"
      "  riskplan-tool import --out=maps/luxembourg --center=49.6116,6.1319 --size_m=8000 \\\n"
      "      --res_m=10 --terrain=elev.tif --population=lux.shp --population_field=POP",
      {"out",
       "name",
       "center",
       "size_m",
       "height_m",
       "bbox",
       "res_m",
       "terrain",
       "fill_terrain",
       "population",
       "population_unit",
       "population_field",
       "fill_density",
       "landcover",
       "landcover_classes",
       "shelter_table",
       "buildings",
       "base_shelter",
       "building_shelter",
       "built_up_full_share",
       "fill_shelter",
       "nofly",
       "nofly_buffer_m",
       "landing",
       "landing_name_field",
       "landing_min_area_m2",
       "max_landing_sites",
       "threads"}};
}

int ImportCommand(int argc, char** argv) {
  auto options = OptionsFromFlags(argc, argv);
  if (!options.ok()) return Fail(options.status());
  const absl::Time start = absl::Now();
  auto imported = geo::ImportMap(*options);
  if (!imported.ok()) return Fail(imported.status());
  const double import_s = absl::ToDoubleSeconds(absl::Now() - start);
  const geo::ImportStats& s = imported->stats;
  MapHeader header = imported->header;
  // RiskMap::Create checks every layer against the format's domains, the
  // importer's result included.
  auto map = RiskMap::Create(std::move(header), std::move(imported->layers));
  if (!map.ok()) return Fail(map.status());
  const std::string out = absl::GetFlag(FLAGS_out);
  std::vector<std::pair<std::string, std::string>> private_fields;
  if (!imported->provenance_json.empty()) {
    private_fields.emplace_back("x_import", imported->provenance_json);
  }
  // Written beside --out and renamed into place: a reader sees the old
  // bundle or the new one (docs/geodata.md, "Provenance").
  if (absl::Status st =
          WriteMapBundleAtomically(**map, out, ExistingDirectory::kReplace, private_fields);
      !st.ok()) {
    return Fail(st);
  }
  const RiskMap& m = **map;
  const double total_s = absl::ToDoubleSeconds(absl::Now() - start);
  const double cells = static_cast<double>(m.nx()) * m.ny();
  std::printf("map           %s: %d x %d cells of %g m (%g x %g m)\n", m.name().c_str(), m.nx(),
              m.ny(), m.res(), m.width_m(), m.height_m());
  std::printf("frame         %s\n", m.header().geo->crs.c_str());
  for (const geo::InputRecord& r : imported->inputs) {
    std::printf("%-13s %s: %s\n", r.layer.c_str(), r.path.c_str(), r.detail.c_str());
  }
  std::printf("terrain       %.1f .. %.1f m AMSL\n", s.terrain_min_m, s.terrain_max_m);
  std::printf("people        %.1f in the map\n", s.people_total);
  std::printf("shelter       %.2f on average\n", s.shelter_mean);
  std::printf("no-fly        %lld cells (%.2f %% of the map)\n",
              static_cast<long long>(s.nofly_cells), 100.0 * s.nofly_cells / cells);
  std::printf("landing sites %zu (%d from the inputs, %d open fields of the land cover)\n",
              m.landing_sites().size(), s.landing_from_inputs, s.landing_from_landcover);
  for (const std::string& note : imported->notes) std::printf("note          %s\n", note.c_str());
  std::printf("wrote %s in %.2f s (import %.2f s)\n", out.c_str(), total_s, import_s);
  return 0;
}

}  // namespace riskplan
