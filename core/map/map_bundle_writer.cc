// The bundle writer: a RiskMap as the files of docs/map-bundle.md, written in
// place (WriteMapBundle) or staged and renamed (WriteMapBundleAtomically).
#include <unistd.h>

#include <bit>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <functional>
#include <set>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "core/map/map_bundle.h"
#include "core/map/map_bundle_format.h"
#include "core/map/staged_directory.h"
#include "nlohmann/json.hpp"

namespace riskplan {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;
// The writer keeps keys in the order of docs/map-bundle.md, for human readers.
using OrderedJson = nlohmann::ordered_json;

// float32 little-endian from float, bit for bit (NaN payloads included).
std::vector<uint8_t> EncodeFloat32(const std::vector<float>& values) {
  std::vector<uint8_t> bytes(values.size() * 4);
  std::memcpy(bytes.data(), values.data(), bytes.size());
  if constexpr (std::endian::native == std::endian::big) {
    for (size_t k = 0; k < bytes.size(); k += 4) {
      std::swap(bytes[k], bytes[k + 3]);
      std::swap(bytes[k + 1], bytes[k + 2]);
    }
  }
  return bytes;
}

// Writes `bytes` to dir/name through a temporary file in the same directory
// and a rename, so a reader never sees a half-written file under `name`.
absl::Status WriteFileAtomically(const fs::path& dir, const std::string& name, const char* data,
                                 size_t size) {
  const fs::path final_path = dir / name;
  const fs::path temp_path = dir / absl::StrCat(".", name, ".tmp-", ::getpid());
  std::error_code ec;
  fs::remove(temp_path, ec);  // left by a writer that died with this pid
  if (absl::Status s = WriteNewFileDurably(temp_path.string(), data, size, final_path.string());
      !s.ok()) {
    return s;
  }
  fs::rename(temp_path, final_path, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(temp_path, ignored);
    return absl::UnavailableError(absl::StrCat("cannot rename '", temp_path.string(), "' to '",
                                               final_path.string(), "': ", ec.message()));
  }
  return absl::OkStatus();
}

// Receives each file of a bundle being written: its name and bytes.
using BundleFileSink =
    std::function<absl::Status(const std::string& name, const char* data, size_t size)>;

using PrivateFields = std::vector<std::pair<std::string, std::string>>;

// The bundle's files, layers first and the manifest last, each into `sink`.
absl::Status WriteBundleFiles(const RiskMap& map, const BundleFileSink& sink,
                              const PrivateFields& private_fields = {}) {
  const MapHeader& h = map.header();
  const MapLayers& l = map.layers();

  OrderedJson manifest = OrderedJson::object();
  manifest["format"] = bundle::kFormatName;
  manifest["version"] = bundle::kFormatVersion;
  manifest["name"] = h.name;
  manifest["x0"] = h.x0;
  manifest["y0"] = h.y0;
  manifest["res"] = h.res;
  manifest["nx"] = h.nx;
  manifest["ny"] = h.ny;
  if (h.geo.has_value()) {
    manifest["geo"] = {{"origin_lat_deg", h.geo->origin_lat_deg},
                       {"origin_lon_deg", h.geo->origin_lon_deg},
                       {"crs", h.geo->crs}};
  }
  manifest["provenance"] = h.provenance;
  OrderedJson sites = OrderedJson::array();
  for (const LandingSite& s : l.landing_sites) {
    sites.push_back({{"name", s.name}, {"i", s.i}, {"j", s.j}});
  }
  manifest["landing_sites"] = std::move(sites);

  // Layers first, manifest last: a reader racing a rewrite sees either the old
  // manifest (whose checksums then refuse the new layers) or the new bundle.
  OrderedJson layer_entries = OrderedJson::object();
  for (const bundle::LayerInfo& info : bundle::kLayers) {
    const std::string name = info.name;
    std::vector<uint8_t> bytes = name == "density"   ? EncodeFloat32(l.density)
                                 : name == "shelter" ? EncodeFloat32(l.shelter)
                                 : name == "terrain" ? EncodeFloat32(l.terrain)
                                                     : map.nofly_layer();
    if (absl::Status s =
            sink(info.default_file, reinterpret_cast<const char*>(bytes.data()), bytes.size());
        !s.ok()) {
      return s;
    }
    layer_entries[name] = {{"file", info.default_file},
                           {"dtype", info.dtype},
                           {"byte_order", bundle::kByteOrder},
                           {"row_order", bundle::kRowOrder},
                           {"sha256", bundle::Sha256Hex(bytes.data(), bytes.size())}};
  }
  manifest["layers"] = std::move(layer_entries);
  for (const auto& [name, json] : private_fields) {
    manifest[name] = OrderedJson::parse(json);
  }
  // Invalid UTF-8 in a name or provenance is replaced rather than thrown on.
  const std::string text =
      manifest.dump(2, ' ', false, OrderedJson::error_handler_t::replace) + "\n";
  return sink(bundle::kManifestName, text.data(), text.size());
}

}  // namespace

absl::Status WriteMapBundle(const RiskMap& map, const std::string& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) {
    return absl::UnavailableError(
        absl::StrCat("cannot create map bundle directory '", dir, "': ", ec.message()));
  }
  return WriteBundleFiles(map, [&](const std::string& name, const char* data, size_t size) {
    return WriteFileAtomically(dir, name, data, size);
  });
}

absl::Status WriteMapBundleAtomically(const RiskMap& map, const std::string& dir,
                                      ExistingDirectory existing,
                                      const PrivateFields& private_fields) {
  std::set<std::string> names;
  for (const auto& [name, json] : private_fields) {
    if (!names.insert(name).second) {
      return absl::InvalidArgumentError(
          absl::StrCat("map bundle: private manifest field '", name, "' is given twice"));
    }
    if (!absl::StartsWith(name, "x_")) {
      return absl::InvalidArgumentError(
          absl::StrCat("map bundle: private manifest field '", name, "' must start with \"x_\""));
    }
    if (!Json::accept(json)) {
      return absl::InvalidArgumentError(
          absl::StrCat("map bundle: private manifest field '", name, "' is not JSON"));
    }
  }
  absl::StatusOr<std::unique_ptr<StagedDirectory>> staged =
      StagedDirectory::Create(dir, existing, bundle::kManifestName);
  if (!staged.ok()) {
    return absl::Status(staged.status().code(),
                        absl::StrCat("map bundle: ", staged.status().message()));
  }
  if (absl::Status s = WriteBundleFiles(
          map,
          [&](const std::string& name, const char* data, size_t size) {
            return (*staged)->WriteFile(name, data, size);
          },
          private_fields);
      !s.ok()) {
    return s;
  }
  return (*staged)->Commit();
}

}  // namespace riskplan
