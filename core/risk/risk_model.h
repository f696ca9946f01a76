// RiskModel: the configuration risk M(q) and the admissibility of a single
// configuration on one map with one parameter set (spec sections 3 and 6).
//
// A RiskModel bundles an immutable RiskMap, its ImpactTable and the glide
// layer that match the parameters; it is immutable and thread-safe, and cheap
// to share (everything heavy is held by shared_ptr).
#ifndef RISKPLAN_CORE_RISK_RISK_MODEL_H_
#define RISKPLAN_CORE_RISK_RISK_MODEL_H_

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/base/model_params.h"
#include "core/base/wind.h"
#include "core/map/risk_map.h"
#include "core/risk/impact_table.h"

namespace riskplan {

// Why a configuration is not admissible, in the order the checks are made.
enum class ViolationKind {
  kNone = 0,
  kOutsideMap,         // (x, y) outside the grid, or x, y, z or theta not finite
  kNoFlyZone,          // cell is a no-fly cell
  kTerrainCollision,   // z <= T(cell)
  kBelowSafeAltitude,  // z < safe_alt(cell) (includes "no landing site reachable")
  kAboveMaxAltitude,   // z > T(cell) + max_agl
  kImpactOutsideMap,   // the impact window reaches past the map (unknown ground)
};

// "OUTSIDE_MAP", "NO_FLY_ZONE", ...
std::string_view ViolationKindName(ViolationKind kind);

// The configuration risk of one configuration and the terms it is made of.
struct ConfigurationRisk {
  double risk = 0.0;                  // M(q), expected casualties given a failure at q
  double impact_factor = 0.0;         // I, people per m^2
  double expected_shelter = 0.0;      // S~
  double casualty_probability = 0.0;  // p_cas
  double exposed_area_m2 = 0.0;       // A_exp
  int height_bin = 0;                 // b
  int heading_bin = 0;                // k
  // False where the spec leaves M undefined: q outside the map or not finite,
  // at or below the terrain, or its impact window reaching past the map.
  bool defined = false;
};

// Where a configuration's risk comes from: M(q) depends on q only through its
// height bin, heading bin and impact cell, so these four numbers are an exact
// cache key for it.
struct KernelSite {
  int height_bin = 0;
  int heading_bin = 0;
  int impact_i = 0;  // impact cell; with its window, inside the map
  int impact_j = 0;
};

// How far the impact window of a configuration at one height above the
// ground reaches, per side of the map, over every heading bin: a
// configuration at (x, y) with that height has its window inside the map, for
// every heading, when x - x0 >= west, (x0 + nx res) - x > east,
// y - y0 >= south and (y0 + ny res) - y > north. In metres; negative when the
// window never reaches that far back (a long fall with a small kernel).
struct ImpactReach {
  int height_bin = 0;
  double west_m = 0.0;
  double east_m = 0.0;
  double south_m = 0.0;
  double north_m = 0.0;
  // The widest of the four: the band along every edge where M is undefined
  // for some heading.
  double Max() const;
  // Cells of `map` whose centre is clear of the reach on every side: there a
  // configuration at this height has a defined M for every heading.
  int64_t CellsClear(const RiskMap& map) const;
};

// A conservative margin in whole cells: every configuration in cell (i, j),
// at any height bin and heading the margin was taken over, has its window
// inside the map when west <= i < nx - east and south <= j < ny - north.
struct CellMargins {
  int west = 0;
  int east = 0;
  int south = 0;
  int north = 0;
  bool Inside(int i, int j, int nx, int ny) const {
    return i >= west && j >= south && i < nx - east && j < ny - north;
  }
};

class RiskModel {
 public:
  // Builds the model. `table` may be passed to share an already built table;
  // it must have the kernel parameters of `params` (SameKernelParams) and the
  // map's cell size. A table in another wind lends its kernel weights to this
  // model's own table (ImpactTable::InWind), which is cheap. The glide layer of the map is
  // reused when the glide parameters match, else computed (about a second on a
  // 1600 x 1600 map). `limits` bound the table built and stop the build
  // (ImpactTable::Build's errors, and Cancelled).
  static absl::StatusOr<std::shared_ptr<const RiskModel>> Create(
      std::shared_ptr<const RiskMap> map, const ModelParams& params,
      std::shared_ptr<const ImpactTable> table = nullptr, const ModelBuildLimits& limits = {});

  // The same model (parameters, impact table, wind) on `map`, which must
  // share the layers of from.map() (RiskMap::WithNoFly) and so differ from it
  // only in its no-fly cells: every configuration risk is from's bit for bit,
  // and admissibility and the glide layer are those of `map`'s no-fly cells.
  // The glide layer is the map's own when the model reads its map's (still
  // air, the map's glide ratio and clearance), else from's repaired for the
  // change (RepairGlideAltitude: the layer Create() would compute, bit for
  // bit, without a map's Dijkstra). InvalidArgument when `map` does not share
  // from's layers; Cancelled once `stop` is reached.
  static absl::StatusOr<std::shared_ptr<const RiskModel>> WithMap(
      const RiskModel& from, std::shared_ptr<const RiskMap> map,
      const StopCondition& stop = StopCondition(), GlideRepairStats* stats = nullptr);

  const RiskMap& map() const { return *map_; }
  const std::shared_ptr<const RiskMap>& map_ptr() const { return map_; }
  const ImpactTable& table() const { return *table_; }
  const std::shared_ptr<const ImpactTable>& table_ptr() const { return table_; }
  const ModelParams& params() const { return params_; }
  // The cruise's wind triangle (spec section 0).
  const WindTriangle& wind() const { return wind_; }

  // M(q) of spec section 3. Never fails: `defined` is false where the spec
  // leaves M undefined (outside the map or not finite, h <= 0, or the impact
  // window reaching past the map).
  ConfigurationRisk Evaluate(const Pose& q) const;

  // Steps 1-3 of spec section 3 and the window rule of step 4: false where M
  // is undefined. Every site it returns has its window inside the map.
  bool Locate(const Pose& q, KernelSite* site) const;
  // True when the (2hw+1)^2 window of `site`'s kernel, centred on its impact
  // cell, lies wholly inside the map (spec version 2, section 3 step 4).
  bool WindowInsideMap(const KernelSite& site) const {
    const int hw = table_->kernel(site.height_bin, site.heading_bin).half_width;
    return site.impact_i >= hw && site.impact_j >= hw && site.impact_i < map_->nx() - hw &&
           site.impact_j < map_->ny() - hw;
  }
  // Steps 5-7 from the EWMM sums of step 4.
  ConfigurationRisk FromSums(const KernelSite& site, double impact_factor,
                             double expected_shelter) const;

  // The EWMM sums alone, for a kernel centred on impact cell (ci, cj).
  // REQUIRES: the window lies inside the map (a site from Locate). Where it
  // does not, both sums are NaN: no number is made up for unknown ground.
  void Ewmm(const ImpactKernel& kernel, int ci, int cj, double* impact_factor,
            double* expected_shelter) const;

  // The reach of the impact window at `height_agl_m` above the ground (its
  // height bin as spec step 2 rounds it), over every heading bin.
  ImpactReach Reach(double height_agl_m) const;
  // Whole-cell margins over every heading bin and every height bin a sample
  // inside the flight band [min_agl, max_agl] can have: a cell outside them
  // may hold an admissible configuration only if some height or heading
  // keeps its window in; a cell inside them never breaks the window rule.
  const CellMargins& band_margins() const { return band_margins_; }
  // The height above the ground below which every configuration in cell
  // (i, j), at any heading, keeps its window inside the map, from whole-cell
  // margins per height bin (conservative like band_margins()): +inf inside
  // band_margins(), -inf where even the flight band's lowest height bin may
  // reach past the map. Near the edges a lower flight is the one allowed:
  // a lower fall lands closer.
  double WindowCeilingAgl(int i, int j) const;

  // Admissibility of one sample (spec section 6), the rules in the spec's
  // order, the impact window last. Also reports the altitude limit that was
  // broken (NaN when the kind has none).
  ViolationKind CheckConfiguration(const Pose& q, double* limit_m = nullptr) const;
  // The same answer for a q whose M(q), `m`, is already known (from Evaluate
  // or any RiskEvaluator: `defined` is exact on every path), without locating
  // q a second time: once the other rules hold, the window lies inside the
  // map exactly when M(q) is defined.
  ViolationKind CheckConfiguration(const Pose& q, const ConfigurationRisk& m,
                                   double* limit_m = nullptr) const;

  // The glide layer safe altitudes read (spec section 6, this model's wind,
  // glide ratio and clearance, the map's no-fly cells): the map's own or one
  // of the model's.
  std::shared_ptr<const std::vector<double>> glide_layer() const {
    return own_glide_ != nullptr ? own_glide_ : map_->glide_altitude_ptr();
  }

  // safe_alt(cell) with this model's glide layer and min_agl.
  // REQUIRES: map().Contains(i, j).
  double SafeAltitude(int i, int j) const;

  // Bytes this model holds beyond its map: the impact table (which other
  // models may share) and a glide layer of its own, if it has one.
  size_t MemoryBytes() const;
  // Bytes of a glide layer of its own (0 when it uses the map's).
  size_t GlideBytes() const;

  // The heading bin of the air heading of track heading `theta` (spec
  // section 3 step 2): table().HeadingBinOf(wind().AirHeading(theta)), bit
  // for bit, read from a table of 4096 track-heading intervals where one bin
  // covers the whole interval (in a wind; in still air the bin of theta
  // itself). The batch locators (accel/batch_locate.cc) read it too.
  int AirHeadingBin(double theta) const {
    if (air_bins_.empty()) return table_->HeadingBinOf(wind_.AirHeading(theta));
    if (theta >= 0.0 && theta < kTwoPi) {
      const int c = static_cast<int>(theta * (kAirBinCells / kTwoPi));
      if (c < kAirBinCells && air_bins_[c] >= 0) return air_bins_[c];
    }
    return table_->HeadingBinOf(wind_.AirHeading(theta));
  }

 private:
  RiskModel() = default;
  // The rules of spec section 6 before the window rule; sets *height_m to
  // q.z - terrain, and *i, *j to q's cell, when they all hold.
  ViolationKind CheckBeforeWindow(const Pose& q, double* limit_m, double* height_m, int* i,
                                  int* j) const;

  // Fills air_bins_ (in a wind).
  void BuildAirBins();

  std::shared_ptr<const RiskMap> map_;
  std::shared_ptr<const ImpactTable> table_;
  ModelParams params_;
  WindTriangle wind_{ModelParams{}};
  // In a wind: the air heading's bin of every track heading in each of
  // kAirBinCells equal intervals of [0, 2 pi), or -1 where an interval comes
  // near a bin boundary (BuildAirBins). Spares the wind triangle's sin, cos,
  // asin and fmod per configuration. Empty in still air.
  static constexpr int kAirBinCells = 4096;
  std::vector<int16_t> air_bins_;
  // Points at the map's own layer or at own_glide_ below.
  const std::vector<double>* glide_ = nullptr;
  std::shared_ptr<const std::vector<double>> own_glide_;
  CellMargins band_margins_;
  // margins_upto_[n]: the margins over height bins [first_band_bin_,
  // first_band_bin_ + n]; the last is band_margins_.
  std::vector<CellMargins> margins_upto_;
  int first_band_bin_ = 1;
};

}  // namespace riskplan

#endif  // RISKPLAN_CORE_RISK_RISK_MODEL_H_
