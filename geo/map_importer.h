// The importer: a map bundle's layers from real geodata (a DEM, a population
// raster or census polygons, a land-cover raster or building footprints,
// no-fly zones, landing sites), each in any CRS and format GDAL reads,
// warped and rasterized onto a grid in the map's local frame
// (geo/target_grid.h). `riskplan-tool import` is its command line;
// docs/geodata.md says what each rule does and why.
//
// Every refusal is InvalidArgument (riskplan-tool exits 2), except an input
// that does not exist or cannot be opened for reading: NotFound, with the
// system's reason ("No such file or directory"; riskplan-tool exits 1).
// Whatever GDAL refuses carries GDAL's own words, from every thread of the
// call (geo/gdal_util.h, GdalErrorCapture). Each names the map layer, the
// input and what is wrong, e.g.
//   layer 'terrain', input 'dem.tif': 1200 of 40000 cells have no data:
//   1200 outside the input's extent, 0 masked (nodata, mask band or alpha);
//   they span local x 0 .. 250 m, y 0 .. 120 m, WGS84 lat 49.6 .. 49.61,
//   lon 6.1 .. 6.11 deg, input CRS EPSG:32632 x ... y ...; give an input
//   that covers the map, or --fill_terrain=METRES|nearest
//
// Thread-compatible: one import per thread at a time (GDAL's own state is
// thread-safe; each import opens its own datasets).
#ifndef RISKPLAN_GEO_MAP_IMPORTER_H_
#define RISKPLAN_GEO_MAP_IMPORTER_H_

#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/map/risk_map.h"
#include "geo/target_grid.h"

namespace riskplan::geo {

// What to put in cells an input leaves without data. Without a rule such
// cells are refused.
struct FillRule {
  enum class Kind { kNone, kValue, kNearest };
  Kind kind = Kind::kNone;
  double value = 0.0;  // kValue: the layer's unit (m AMSL, people per m^2, shelter)
};

// Parses "none", "nearest" (when allowed) or a number; InvalidArgument names
// `flag`.
absl::StatusOr<FillRule> ParseFillRule(const std::string& flag, const std::string& text,
                                       bool nearest_allowed);

// A vector input: a path, optionally followed by QGIS-style options,
// "PATH|layername=NAME|where=SQL".
struct VectorSpec {
  std::string path;
  std::string layer_name;  // "" for the default layer
  std::string where;       // OGR SQL attribute filter, "" for none
};
absl::StatusOr<VectorSpec> ParseVectorSpec(const std::string& text);

enum class PopulationUnit { kPerCell, kPerKm2 };

struct ImportOptions {
  std::string name;  // the map's name, [a-z0-9._-]{1,64}
  AreaSpec area;
  int threads = 1;           // GDAL warp threads
  std::string command_line;  // recorded in the provenance

  // Terrain (required): a DEM raster, m above mean sea level (feet are
  // converted when the band says so), resampled bilinearly.
  std::string terrain;
  FillRule terrain_fill;  // kValue or kNearest (the nearest cell with data)

  // Population (optional; density 0 everywhere without it): a raster, or
  // polygons with a count attribute (census areas).
  std::string population;  // raster path, or vector spec (see VectorSpec)
  PopulationUnit population_unit = PopulationUnit::kPerCell;  // rasters
  std::string population_field;                               // polygons: the count
  FillRule density_fill;                                      // people per m^2

  // Shelter: a land-cover raster of classes with a class table, and/or
  // building footprints; neither: base_shelter everywhere.
  std::string landcover;
  std::string landcover_classes = "worldcover";  // or "corine"
  std::string shelter_table_file;                // rules applied on top, "" for none
  std::string buildings;                         // vector spec
  double base_shelter = 2.5;                     // where no land cover is given
  double building_shelter = 7.5;                 // a cell fully built up
  double built_up_full_share = 0.5;  // a share of roofs this high counts as fully built up
  FillRule shelter_fill;

  // No-fly zones: polygons (points and lines too when buffered), grown by
  // nofly_buffer_m.
  std::vector<std::string> nofly;  // vector specs
  double nofly_buffer_m = 0.0;

  // Landing sites: points (the cell under each) or polygons (the cell
  // deepest inside each), and/or open fields of the land cover of at least
  // landing_min_area_m2. Never inside a no-fly cell.
  std::vector<std::string> landing;  // vector specs
  std::string landing_name_field;
  double landing_min_area_m2 = 0.0;  // 0: no fields derived from land cover
  int max_landing_sites = 1000;      // derived fields kept, the largest first
};

// One input as the provenance records it.
struct InputRecord {
  std::string layer;  // "terrain", "population", ...
  std::string path;
  std::string driver;   // GDAL's short name
  std::string crs;      // "EPSG:4326", or a name
  std::string crs_wkt;  // WKT2, one line
  std::string detail;   // resampling, fields, filters, counts
};

// What an import found, for the summary and the tests.
struct ImportStats {
  double people_total = 0.0;  // sum of density * res^2 over the map
  int64_t nofly_cells = 0;
  int64_t filled_terrain_cells = 0;
  int64_t filled_density_cells = 0;
  int64_t filled_shelter_cells = 0;
  double terrain_min_m = 0.0;
  double terrain_max_m = 0.0;
  double shelter_mean = 0.0;
  int landing_from_inputs = 0;
  int landing_from_landcover = 0;
  int landing_dropped_nofly = 0;
  int landing_outside_map = 0;
};

struct ImportedMap {
  MapHeader header;  // with geo and provenance set
  MapLayers layers;
  ImportStats stats;
  std::vector<InputRecord> inputs;
  std::vector<std::string> notes;  // one line each: choices made, sites dropped, timings
  // The structured provenance (inputs, CRSs, frame, command line) as a JSON
  // object, written into the manifest as "x_import".
  std::string provenance_json;
};

// Runs the whole import. Validates the options and the grid's size before
// anything is read or allocated.
absl::StatusOr<ImportedMap> ImportMap(const ImportOptions& options);

}  // namespace riskplan::geo

#endif  // RISKPLAN_GEO_MAP_IMPORTER_H_
