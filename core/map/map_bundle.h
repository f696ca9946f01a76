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
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/model_params.h"
#include "core/map/risk_map.h"
#include "core/map/staged_directory.h"

namespace riskplan {

// Loads and validates the bundle in directory `dir`. The glide-altitude layer is
// derived with params.glide_ratio and params.glide_clearance_m.
absl::StatusOr<std::shared_ptr<const RiskMap>> LoadMapBundle(const std::string& dir,
                                                             const ModelParams& params = {});

// Writes `map` as a bundle at `dir` so that `dir` is, at every moment, either
// what it was before or the complete new bundle, never a partial one: not on
// a full disk, a read-only mount or under a file size limit, not when the
// process dies. The bundle is written into a temporary sibling directory
// (`.NAME.tmp-XXXXXX`, beside `dir`), every file and the directory flushed
// to disk, then renamed to `dir` (StagedDirectory). With kRefuse (the
// default) an existing `dir` is left alone (AlreadyExists); with kReplace an
// existing bundle (or empty directory) is replaced in one step, and anything
// else at `dir` is refused (FailedPrecondition). Missing parent directories
// are created. On failure nothing of the new bundle is left behind, and the
// error names the file at fault and the system's reason, e.g. "cannot write
// 'maps/city/density.f32': No space left on device". The written bundle
// loads back bit for bit. Every program that writes bundles for others to
// load (riskplan-tool write-map, importers) writes them with this.
//
// `private_fields` adds members to the manifest after the format's own, each
// a name starting with "x_" (the prefix readers ignore, docs/map-bundle.md)
// and its value as JSON text, e.g. an importer's {"x_import", "{...}"}
// (provenance). A name without the prefix, a name given twice or a value that
// is not JSON is refused (InvalidArgument) before anything is written.
absl::Status WriteMapBundleAtomically(
    const RiskMap& map, const std::string& dir,
    ExistingDirectory existing = ExistingDirectory::kRefuse,
    const std::vector<std::pair<std::string, std::string>>& private_fields = {});

// Writes `map` as a bundle into `dir` in place (created if missing; existing
// bundle files are replaced, other files are left): each file through its own
// temporary file and rename, so no file is ever half-written, but a failure
// part way leaves some layers new and the old manifest (whose checksums then
// refuse them). For tests and tools that own `dir`; prefer
// WriteMapBundleAtomically. The written bundle loads back bit for bit.
absl::Status WriteMapBundle(const RiskMap& map, const std::string& dir);

// Loads every bundle found in the immediate sub-directories of `dir` that hold a
// manifest.json, sorted by directory name, except those whose name starts with
// '.' (such as the temporary directory of a write that was interrupted). Fails
// on the first bad bundle, or on two bundles with the same map name.
absl::StatusOr<std::vector<std::shared_ptr<const RiskMap>>> LoadMapDirectory(
    const std::string& dir, const ModelParams& params = {});

}  // namespace riskplan

#endif  // RISKPLAN_CORE_MAP_MAP_BUNDLE_H_
