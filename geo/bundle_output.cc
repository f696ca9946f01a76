#include "geo/bundle_output.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <system_error>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/map/map_bundle.h"

namespace riskplan::geo {
namespace {

namespace fs = std::filesystem;

absl::Status Unavailable(const std::string& what, const std::error_code& ec) {
  return absl::UnavailableError(absl::StrCat(what, ": ", ec.message()));
}

// Adds "x_import" to the manifest WriteMapBundle wrote (a JSON object ending
// in "}\n"), keeping its layout.
absl::Status AddToManifest(const fs::path& manifest, const std::string& json) {
  std::ifstream in(manifest, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  std::string text = buffer.str();
  const size_t close = text.rfind('}');
  if (!in || close == std::string::npos) {
    return absl::UnavailableError(absl::StrCat("cannot read back '", manifest.string(), "'"));
  }
  text.insert(close, absl::StrCat(",\n  \"x_import\": ", json, "\n"));
  std::ofstream out(manifest, std::ios::binary | std::ios::trunc);
  out << text;
  out.close();
  if (!out) return absl::UnavailableError(absl::StrCat("cannot write '", manifest.string(), "'"));
  return absl::OkStatus();
}

}  // namespace

absl::Status WriteBundleReplacing(const RiskMap& map, const std::string& dir,
                                  const std::string& x_import_json) {
  const fs::path target = fs::absolute(fs::path(dir)).lexically_normal();
  const fs::path parent = target.parent_path();
  const std::string leaf = target.filename().string();
  std::error_code ec;
  if (fs::exists(target, ec)) {
    const bool bundle = fs::is_regular_file(target / "manifest.json", ec);
    const bool empty = fs::is_directory(target, ec) && fs::is_empty(target, ec);
    if (!bundle && !empty) {
      return absl::FailedPreconditionError(absl::StrCat(
          "'", dir,
          "' exists and is neither a map bundle nor an empty directory; not replacing it"));
    }
  }
  fs::create_directories(parent, ec);
  if (ec) return Unavailable(absl::StrCat("cannot create '", parent.string(), "'"), ec);
  const fs::path temp = parent / absl::StrCat(".", leaf, ".import-", ::getpid());
  const fs::path old = parent / absl::StrCat(".", leaf, ".old-", ::getpid());
  fs::remove_all(temp, ec);
  if (absl::Status s = WriteMapBundle(map, temp.string()); !s.ok()) {
    fs::remove_all(temp, ec);
    return s;
  }
  if (!x_import_json.empty()) {
    if (absl::Status s = AddToManifest(temp / "manifest.json", x_import_json); !s.ok()) {
      fs::remove_all(temp, ec);
      return s;
    }
  }
  // Two renames: the old bundle aside, the new one in. A directory cannot be
  // renamed over a non-empty one.
  const bool had_old = fs::exists(target, ec);
  if (had_old) {
    fs::rename(target, old, ec);
    if (ec) {
      std::error_code ignored;
      fs::remove_all(temp, ignored);
      return Unavailable(absl::StrCat("cannot move the old '", dir, "' aside"), ec);
    }
  }
  fs::rename(temp, target, ec);
  if (ec) {
    std::error_code ignored;
    if (had_old) fs::rename(old, target, ignored);
    fs::remove_all(temp, ignored);
    return Unavailable(absl::StrCat("cannot rename the new bundle to '", dir, "'"), ec);
  }
  if (had_old) fs::remove_all(old, ec);
  return absl::OkStatus();
}

}  // namespace riskplan::geo
