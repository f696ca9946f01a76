// The importer's steps, one per map layer (geo/map_importer.cc runs them in
// order). Internal to geo/.
#ifndef RISKPLAN_GEO_IMPORT_STEPS_H_
#define RISKPLAN_GEO_IMPORT_STEPS_H_

#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "geo/gdal_util.h"
#include "geo/map_importer.h"
#include "geo/shelter_table.h"
#include "geo/target_grid.h"

namespace riskplan::geo::internal {

// What every step reads and adds to.
struct ImportContext {
  const ImportOptions& options;
  TargetGrid grid;
  SpatialReferencePtr frame_srs;
  ImportedMap* out;

  // The buildings' built-up share of each cell, once read (BuiltUpShare).
  std::optional<std::vector<float>> built_up;

  double cell_area_m2() const { return grid.res_m * grid.res_m; }
  void Note(const std::string& line) { out->notes.push_back(line); }
};

// The land-cover classes of the map's cells, when a land-cover raster is
// given (NaN where it has none), and the table that reads them.
struct LandCover {
  std::vector<double> classes;
  ShelterTable table;
};

// The rule of a cell's class, or nullptr for a class the table lacks. Looks
// the table up only when the class changes from the last call's (land cover
// comes in runs of one class).
class ClassRules {
 public:
  explicit ClassRules(const ShelterTable& table) : table_(table) {}
  const ClassRule* Find(double cls) {
    if (cls != last_) {
      last_ = cls;
      auto it = table_.rules.find(static_cast<int>(cls));
      rule_ = it == table_.rules.end() ? nullptr : &it->second;
    }
    return rule_;
  }

 private:
  const ShelterTable& table_;
  double last_ = std::nan("");
  const ClassRule* rule_ = nullptr;
};

// Terrain, m AMSL, south row first.
absl::StatusOr<std::vector<float>> ImportTerrain(ImportContext& ctx);

// Density, people per m^2 (all 0 without a population input).
absl::StatusOr<std::vector<float>> ImportPopulation(ImportContext& ctx);

// The land-cover classes, or nullopt without a land-cover input.
absl::StatusOr<std::optional<LandCover>> ImportLandCover(ImportContext& ctx);

// The share of each cell's area under the buildings input's polygons, read
// and rasterized on the first call (and recorded as an input), then kept in
// ctx.built_up. REQUIRES: !ctx.options.buildings.empty().
absl::StatusOr<const std::vector<float>*> BuiltUpShare(ImportContext& ctx);

// True for polygons and multipolygons (curved ones too).
bool IsPolygonal(const OGRGeometry& g);

// Shelter in [0, 10] from the land cover and the buildings.
absl::StatusOr<std::vector<float>> ImportShelter(ImportContext& ctx,
                                                 const std::optional<LandCover>& land_cover);

// No-fly flags (0 or 1).
absl::StatusOr<std::vector<uint8_t>> ImportNoFly(ImportContext& ctx);

// Landing sites from the inputs and the land cover, none in a no-fly cell.
absl::StatusOr<std::vector<LandingSite>> ImportLandingSites(
    ImportContext& ctx, const std::optional<LandCover>& land_cover,
    const std::vector<uint8_t>& nofly);

// The refusal for the cells of `missing` (nonzero: no data) of a layer:
// how many, how many of them lie outside the input's extent (`outside`,
// nonzero where the input does not reach; may be empty when unknown), and
// the extent they span in the local frame, WGS84 and the input's CRS. `fix`
// says how to get past it ("--fill_terrain=METRES|nearest").
absl::Status MissingCellsError(const ImportContext& ctx, const std::string& label,
                               const OGRSpatialReference* input_srs,
                               const std::vector<uint8_t>& missing,
                               const std::vector<uint8_t>& outside, const std::string& fix);

// Fills the NaN cells of `values` by `rule` (kValue, or kNearest: the value
// of the nearest cell that has one, by 8-connected chamfer distance); returns
// how many were filled. REQUIRES: rule.kind != kNone, values.size() == nx*ny.
int64_t FillMissing(const FillRule& rule, int nx, int ny, std::vector<double>* values);

}  // namespace riskplan::geo::internal

#endif  // RISKPLAN_GEO_IMPORT_STEPS_H_
