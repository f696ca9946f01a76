// RiskModel: the configuration risk M(q) and the admissibility of a single
// configuration on one map with one parameter set (spec sections 3 and 6).
//
// A RiskModel bundles an immutable RiskMap, its ImpactTable and the glide
// layer that match the parameters; it is immutable and thread-safe, and cheap
// to share (everything heavy is held by shared_ptr).
#ifndef RISKPLAN_CORE_RISK_RISK_MODEL_H_
#define RISKPLAN_CORE_RISK_RISK_MODEL_H_

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/base/model_params.h"
#include "core/map/risk_map.h"
#include "core/risk/impact_table.h"

namespace riskplan {

// Why a configuration is not admissible, in the order the checks are made.
enum class ViolationKind {
  kNone = 0,
  kOutsideMap,         // (x, y) outside the grid, or not finite
  kNoFlyZone,          // cell is a no-fly cell
  kTerrainCollision,   // z <= T(cell)
  kBelowSafeAltitude,  // z < safe_alt(cell) (includes "no landing site reachable")
  kAboveMaxAltitude,   // z > T(cell) + max_agl
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
  bool defined = false;               // false when q is outside the map or at/below the terrain
};

// Where a configuration's risk comes from: M(q) depends on q only through its
// height bin, heading bin and impact cell, so these four numbers are an exact
// cache key for it.
struct KernelSite {
  int height_bin = 0;
  int heading_bin = 0;
  int impact_i = 0;  // impact cell (may lie outside the map)
  int impact_j = 0;
};

class RiskModel {
 public:
  // Builds the model. `table` may be passed to share an already built table;
  // it must match params and the map's cell size. The glide layer of the map is
  // reused when the glide parameters match, else computed (about a second on a
  // 1600 x 1600 map). `limits` bound the table built and stop the build
  // (ImpactTable::Build's errors, and Cancelled).
  static absl::StatusOr<std::shared_ptr<const RiskModel>> Create(
      std::shared_ptr<const RiskMap> map, const ModelParams& params,
      std::shared_ptr<const ImpactTable> table = nullptr, const ModelBuildLimits& limits = {});

  const RiskMap& map() const { return *map_; }
  const std::shared_ptr<const RiskMap>& map_ptr() const { return map_; }
  const ImpactTable& table() const { return *table_; }
  const std::shared_ptr<const ImpactTable>& table_ptr() const { return table_; }
  const ModelParams& params() const { return params_; }

  // M(q) of spec section 3. Never fails: `defined` is false where the spec
  // leaves M undefined (outside the map, h <= 0).
  ConfigurationRisk Evaluate(const Pose& q) const;

  // Steps 1-3 of spec section 3: false where M is undefined.
  bool Locate(const Pose& q, KernelSite* site) const;
  // Steps 5-7 from the EWMM sums of step 4.
  ConfigurationRisk FromSums(const KernelSite& site, double impact_factor,
                             double expected_shelter) const;

  // The EWMM sums alone, for a kernel centred on impact cell (ci, cj), which
  // may lie outside the map (out-of-map cells read density 0, shelter 10).
  void Ewmm(const ImpactKernel& kernel, int ci, int cj, double* impact_factor,
            double* expected_shelter) const;

  // Admissibility of one sample (spec section 6). Also reports the altitude
  // limit that was broken (NaN when the kind has none).
  ViolationKind CheckConfiguration(const Pose& q, double* limit_m = nullptr) const;

  // safe_alt(cell) with this model's glide layer and min_agl.
  // REQUIRES: map().Contains(i, j).
  double SafeAltitude(int i, int j) const;

  // Bytes this model holds beyond its map: the impact table (which other
  // models may share) and a glide layer of its own, if it has one.
  size_t MemoryBytes() const;

 private:
  RiskModel() = default;

  std::shared_ptr<const RiskMap> map_;
  std::shared_ptr<const ImpactTable> table_;
  ModelParams params_;
  // Points at the map's own layer or at own_glide_ below.
  const std::vector<double>* glide_ = nullptr;
  std::shared_ptr<const std::vector<double>> own_glide_;
};

}  // namespace riskplan

#endif  // RISKPLAN_CORE_RISK_RISK_MODEL_H_
