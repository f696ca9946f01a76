// Map bundles: the on-disk form of a RiskMap (docs/map-bundle.md is the
// normative description of the format).
//
// A bundle is one directory holding `manifest.json` and one raw raster file per
// layer. LoadMapBundle() validates everything and refuses a bad bundle with an
// InvalidArgument (or NotFound for missing files) that names the file, layer,
// cell and value at fault.
#ifndef RISKPLAN_CORE_MAP_MAP_BUNDLE_H_
#define RISKPLAN_CORE_MAP_MAP_BUNDLE_H_

#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/model_params.h"
#include "core/map/risk_map.h"

namespace riskplan {

// Loads and validates the bundle in directory `dir`. The glide-altitude layer is
// derived with params.glide_ratio and params.glide_clearance_m.
absl::StatusOr<std::shared_ptr<const RiskMap>> LoadMapBundle(const std::string& dir,
                                                             const ModelParams& params = {});

// Writes `map` as a bundle into `dir` (created if missing; existing bundle files
// are replaced). The written bundle loads back bit for bit.
absl::Status WriteMapBundle(const RiskMap& map, const std::string& dir);

// Loads every bundle found in the immediate sub-directories of `dir` that hold a
// manifest.json, sorted by directory name. Fails on the first bad bundle, or on
// two bundles with the same map name.
absl::StatusOr<std::vector<std::shared_ptr<const RiskMap>>> LoadMapDirectory(
    const std::string& dir, const ModelParams& params = {});

}  // namespace riskplan

#endif  // RISKPLAN_CORE_MAP_MAP_BUNDLE_H_
