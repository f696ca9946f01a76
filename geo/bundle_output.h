// Writing an imported map: the bundle appears whole at its path or not at all.
#ifndef RISKPLAN_GEO_BUNDLE_OUTPUT_H_
#define RISKPLAN_GEO_BUNDLE_OUTPUT_H_

#include <string>

#include "absl/status/status.h"
#include "core/map/risk_map.h"

namespace riskplan::geo {

// Writes `map` as a bundle (WriteMapBundle) into a temporary sibling of
// `dir`, adds `x_import_json` (a JSON object, or "" for none) to its manifest
// as the private field "x_import", and renames it into place: a reader sees
// the old bundle or the new one, never a mix. An existing `dir` must be a map
// bundle (it holds manifest.json) or empty; it is replaced. Unavailable on a
// file-system error, FailedPrecondition for an existing `dir` that is
// neither.
absl::Status WriteBundleReplacing(const RiskMap& map, const std::string& dir,
                                  const std::string& x_import_json);

}  // namespace riskplan::geo

#endif  // RISKPLAN_GEO_BUNDLE_OUTPUT_H_
