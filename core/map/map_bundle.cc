// The bundle loader: LoadMapBundle and LoadMapDirectory (the writer is
// map_bundle_writer.cc).
#include "core/map/map_bundle.h"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "core/map/map_bundle_format.h"
#include "nlohmann/json.hpp"

namespace riskplan {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

// A manifest is small; refusing huge ones keeps a hostile bundle from making
// the loader allocate without bound before any other check.
constexpr uintmax_t kMaxManifestBytes = 64u << 20;

struct LayerEntry {
  std::string file;
  std::string sha256;  // lower-case hex, empty when the manifest gives none
};

absl::Status Invalid(absl::string_view dir, absl::string_view message) {
  return absl::InvalidArgumentError(absl::StrCat("map bundle '", dir, "': ", message));
}

// Prefixes an error from a lower layer (RiskMap::Create) with the bundle.
absl::Status InBundle(absl::string_view dir, const absl::Status& status) {
  return absl::Status(status.code(), absl::StrCat("map bundle '", dir, "': ", status.message()));
}

// Typed access to manifest fields. `path` is the dotted name used in messages,
// e.g. "layers.density.file" or "landing_sites[3].i".
class ManifestReader {
 public:
  explicit ManifestReader(std::string dir) : dir_(std::move(dir)) {}

  absl::StatusOr<const Json*> Field(const Json& object, const std::string& prefix,
                                    const char* key) const {
    auto it = object.find(key);
    if (it == object.end()) {
      return Invalid(dir_, absl::StrCat("manifest.json: missing field '", prefix, key, "'"));
    }
    return &*it;
  }

  absl::Status TypeError(const std::string& path, const char* wanted, const Json& value) const {
    return Invalid(dir_, absl::StrCat("manifest.json: field '", path, "' must be ", wanted,
                                      ", got ", value.type_name()));
  }

  absl::StatusOr<std::string> String(const Json& object, const std::string& prefix,
                                     const char* key) const {
    absl::StatusOr<const Json*> v = Field(object, prefix, key);
    if (!v.ok()) return v.status();
    if (!(*v)->is_string()) return TypeError(prefix + key, "a string", **v);
    return (*v)->get<std::string>();
  }

  absl::StatusOr<double> Number(const Json& object, const std::string& prefix,
                                const char* key) const {
    absl::StatusOr<const Json*> v = Field(object, prefix, key);
    if (!v.ok()) return v.status();
    if (!(*v)->is_number()) return TypeError(prefix + key, "a number", **v);
    return (*v)->get<double>();
  }

  // An integer written without fraction or exponent, within int's range.
  absl::StatusOr<int> Int(const Json& object, const std::string& prefix, const char* key) const {
    absl::StatusOr<const Json*> v = Field(object, prefix, key);
    if (!v.ok()) return v.status();
    const Json& j = **v;
    if (!j.is_number_integer()) return TypeError(prefix + key, "an integer", j);
    const bool fits = j.is_number_unsigned()
                          ? j.get<uint64_t>() <= uint64_t{std::numeric_limits<int>::max()}
                          : (j.get<int64_t>() >= std::numeric_limits<int>::min() &&
                             j.get<int64_t>() <= std::numeric_limits<int>::max());
    if (!fits) {
      return Invalid(dir_, absl::StrCat("manifest.json: field '", prefix, key, "' has value ",
                                        j.dump(), "; it must fit a 32-bit signed integer"));
    }
    return static_cast<int>(j.get<int64_t>());
  }

  absl::Status Expect(const Json& object, const std::string& prefix, const char* key,
                      const char* expected) const {
    absl::StatusOr<std::string> v = String(object, prefix, key);
    if (!v.ok()) return v.status();
    if (*v != expected) {
      return Invalid(dir_, absl::StrCat("manifest.json: field '", prefix, key, "' is '", *v,
                                        "'; expected '", expected, "'"));
    }
    return absl::OkStatus();
  }

  const std::string& dir() const { return dir_; }

 private:
  std::string dir_;
};

bool IsPlainFileName(const std::string& name) {
  return !name.empty() && name != "." && name != ".." &&
         name.find_first_of("/\\") == std::string::npos && name.find('\0') == std::string::npos;
}

absl::StatusOr<LayerEntry> ReadLayerEntry(const ManifestReader& reader, const Json& layers,
                                          const bundle::LayerInfo& info) {
  const std::string prefix = absl::StrCat("layers.", info.name, ".");
  absl::StatusOr<const Json*> entry = reader.Field(layers, "layers.", info.name);
  if (!entry.ok()) return entry.status();
  if (!(*entry)->is_object()) {
    return reader.TypeError(absl::StrCat("layers.", info.name), "an object", **entry);
  }
  const Json& e = **entry;
  LayerEntry out;
  absl::StatusOr<std::string> file = reader.String(e, prefix, "file");
  if (!file.ok()) return file.status();
  if (!IsPlainFileName(*file)) {
    return Invalid(reader.dir(),
                   absl::StrCat("manifest.json: field '", prefix, "file' is '", *file,
                                "'; expected a plain file name inside the bundle directory"));
  }
  out.file = *file;
  for (auto [key, expected] :
       {std::pair{"dtype", info.dtype}, std::pair{"byte_order", bundle::kByteOrder},
        std::pair{"row_order", bundle::kRowOrder}}) {
    if (absl::Status s = reader.Expect(e, prefix, key, expected); !s.ok()) return s;
  }
  if (e.contains("sha256")) {
    absl::StatusOr<std::string> sha = reader.String(e, prefix, "sha256");
    if (!sha.ok()) return sha.status();
    std::string hex = *sha;
    bool ok = hex.size() == 64;
    for (char& c : hex) {
      if (c >= 'A' && c <= 'F') c = static_cast<char>(c - 'A' + 'a');
      ok = ok && ((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'));
    }
    if (!ok) {
      return Invalid(reader.dir(), absl::StrCat("manifest.json: field '", prefix,
                                                "sha256' must be 64 hexadecimal digits"));
    }
    out.sha256 = hex;
  }
  return out;
}

absl::StatusOr<std::vector<LandingSite>> ReadLandingSites(const ManifestReader& reader,
                                                          const Json& manifest) {
  std::vector<LandingSite> sites;
  if (!manifest.contains("landing_sites")) return sites;
  const Json& list = manifest["landing_sites"];
  if (!list.is_array()) return reader.TypeError("landing_sites", "an array", list);
  sites.reserve(list.size());
  for (size_t k = 0; k < list.size(); ++k) {
    const std::string prefix = absl::StrCat("landing_sites[", k, "].");
    if (!list[k].is_object()) {
      return reader.TypeError(absl::StrCat("landing_sites[", k, "]"), "an object", list[k]);
    }
    LandingSite site;
    if (list[k].contains("name")) {
      absl::StatusOr<std::string> name = reader.String(list[k], prefix, "name");
      if (!name.ok()) return name.status();
      site.name = *name;
    }
    absl::StatusOr<int> i = reader.Int(list[k], prefix, "i");
    if (!i.ok()) return i.status();
    absl::StatusOr<int> j = reader.Int(list[k], prefix, "j");
    if (!j.ok()) return j.status();
    site.i = *i;
    site.j = *j;
    sites.push_back(std::move(site));
  }
  return sites;
}

// Reads the header, landing sites and layer entries of a parsed manifest.
absl::Status ReadManifest(const ManifestReader& reader, const Json& manifest, MapHeader* header,
                          std::vector<LandingSite>* sites, LayerEntry (&entries)[4]) {
  if (!manifest.is_object()) {
    return Invalid(reader.dir(), absl::StrCat("manifest.json: top level must be an object, got ",
                                              manifest.type_name()));
  }
  if (absl::Status s = reader.Expect(manifest, "", "format", bundle::kFormatName); !s.ok()) {
    return s;
  }
  absl::StatusOr<const Json*> version = reader.Field(manifest, "", "version");
  if (!version.ok()) return version.status();
  if (!(*version)->is_number_integer()) return reader.TypeError("version", "an integer", **version);
  if (**version != bundle::kFormatVersion) {
    return Invalid(reader.dir(),
                   absl::StrCat("manifest.json: unsupported version ", (*version)->dump(),
                                "; this build reads version ", bundle::kFormatVersion));
  }

  absl::StatusOr<std::string> name = reader.String(manifest, "", "name");
  if (!name.ok()) return name.status();
  header->name = *name;
  for (auto [key, field] : {std::pair{"x0", &header->x0}, std::pair{"y0", &header->y0},
                            std::pair{"res", &header->res}}) {
    absl::StatusOr<double> v = reader.Number(manifest, "", key);
    if (!v.ok()) return v.status();
    *field = *v;
  }
  for (auto [key, field] : {std::pair{"nx", &header->nx}, std::pair{"ny", &header->ny}}) {
    absl::StatusOr<int> v = reader.Int(manifest, "", key);
    if (!v.ok()) return v.status();
    *field = *v;
  }
  if (manifest.contains("provenance")) {
    absl::StatusOr<std::string> v = reader.String(manifest, "", "provenance");
    if (!v.ok()) return v.status();
    header->provenance = *v;
  }
  if (manifest.contains("geo")) {
    const Json& geo = manifest["geo"];
    if (!geo.is_object()) return reader.TypeError("geo", "an object", geo);
    GeoReference ref;
    absl::StatusOr<double> lat = reader.Number(geo, "geo.", "origin_lat_deg");
    if (!lat.ok()) return lat.status();
    absl::StatusOr<double> lon = reader.Number(geo, "geo.", "origin_lon_deg");
    if (!lon.ok()) return lon.status();
    ref.origin_lat_deg = *lat;
    ref.origin_lon_deg = *lon;
    if (geo.contains("crs")) {
      absl::StatusOr<std::string> crs = reader.String(geo, "geo.", "crs");
      if (!crs.ok()) return crs.status();
      ref.crs = *crs;
    }
    header->geo = std::move(ref);
  }

  absl::StatusOr<std::vector<LandingSite>> landing = ReadLandingSites(reader, manifest);
  if (!landing.ok()) return landing.status();
  *sites = *std::move(landing);

  absl::StatusOr<const Json*> layers = reader.Field(manifest, "", "layers");
  if (!layers.ok()) return layers.status();
  if (!(*layers)->is_object()) return reader.TypeError("layers", "an object", **layers);
  for (int k = 0; k < 4; ++k) {
    absl::StatusOr<LayerEntry> entry = ReadLayerEntry(reader, **layers, bundle::kLayers[k]);
    if (!entry.ok()) return entry.status();
    entries[k] = *std::move(entry);
  }
  return absl::OkStatus();
}

// Reads one raster file after checking its size against the header and its
// checksum against the manifest.
absl::StatusOr<std::vector<uint8_t>> ReadLayerFile(const std::string& dir,
                                                   const bundle::LayerInfo& info,
                                                   const LayerEntry& entry, int64_t cells) {
  const fs::path path = fs::path(dir) / entry.file;
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) {
    return absl::NotFoundError(absl::StrCat("map bundle '", dir, "': layer '", info.name,
                                            "': file '", entry.file, "' not found"));
  }
  const uintmax_t actual = fs::file_size(path, ec);
  const uintmax_t expected = static_cast<uintmax_t>(cells) * info.bytes_per_cell;
  if (ec || actual != expected) {
    return Invalid(dir, absl::StrCat("layer '", info.name, "': file '", entry.file, "' has ",
                                     ec ? 0 : actual, " bytes; expected ", expected,
                                     " (nx*ny = ", cells, " cells of ", info.dtype, ")"));
  }
  std::vector<uint8_t> bytes(expected);
  std::ifstream in(path, std::ios::binary);
  if (!in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(expected))) {
    return absl::UnavailableError(absl::StrCat("map bundle '", dir, "': layer '", info.name,
                                               "': cannot read file '", entry.file, "'"));
  }
  if (!entry.sha256.empty()) {
    const std::string actual_sha = bundle::Sha256Hex(bytes.data(), bytes.size());
    if (actual_sha != entry.sha256) {
      return Invalid(dir,
                     absl::StrCat("layer '", info.name, "': file '", entry.file, "' has SHA-256 ",
                                  actual_sha, "; manifest.json says ", entry.sha256));
    }
  }
  return bytes;
}

// float32 little-endian to float, bit for bit (NaN payloads included).
std::vector<float> DecodeFloat32(const std::vector<uint8_t>& bytes) {
  std::vector<float> values(bytes.size() / 4);
  std::memcpy(values.data(), bytes.data(), values.size() * 4);
  if constexpr (std::endian::native == std::endian::big) {
    for (float& v : values) v = std::bit_cast<float>(__builtin_bswap32(std::bit_cast<uint32_t>(v)));
  }
  return values;
}

}  // namespace

absl::StatusOr<std::shared_ptr<const RiskMap>> LoadMapBundle(const std::string& dir,
                                                             const ModelParams& params) {
  const fs::path manifest_path = fs::path(dir) / bundle::kManifestName;
  std::error_code ec;
  if (!fs::is_regular_file(manifest_path, ec)) {
    return absl::NotFoundError(absl::StrCat("map bundle '", dir, "': manifest.json not found"));
  }
  const uintmax_t manifest_size = fs::file_size(manifest_path, ec);
  if (ec || manifest_size > kMaxManifestBytes) {
    return Invalid(dir, absl::StrCat("manifest.json is larger than ", kMaxManifestBytes, " bytes"));
  }
  std::string text(manifest_size, '\0');
  std::ifstream in(manifest_path, std::ios::binary);
  if (!in.read(text.data(), static_cast<std::streamsize>(text.size()))) {
    return absl::UnavailableError(
        absl::StrCat("map bundle '", dir, "': cannot read manifest.json"));
  }

  // nlohmann::json reports the position of a syntax error only through its
  // exception; it is caught right here and never crosses our API.
  Json manifest;
  try {
    manifest = Json::parse(text);
  } catch (const Json::exception& e) {
    std::string what = e.what();
    // Drop nlohmann's "[json.exception.parse_error.101] " tag.
    if (size_t close = what.find("] ");
        what.rfind("[json.exception", 0) == 0 && close != std::string::npos) {
      what = what.substr(close + 2);
    }
    return Invalid(dir, absl::StrCat("manifest.json is not valid JSON: ", what));
  }

  ManifestReader reader(dir);
  MapHeader header;
  MapLayers layers;
  LayerEntry entries[4];
  if (absl::Status s = ReadManifest(reader, manifest, &header, &layers.landing_sites, entries);
      !s.ok()) {
    return s;
  }
  // Size buffers only from a checked header.
  if (absl::Status s = ValidateMapHeader(header); !s.ok()) return InBundle(dir, s);
  const int64_t cells = static_cast<int64_t>(header.nx) * header.ny;

  for (int k = 0; k < 4; ++k) {
    absl::StatusOr<std::vector<uint8_t>> bytes =
        ReadLayerFile(dir, bundle::kLayers[k], entries[k], cells);
    if (!bytes.ok()) return bytes.status();
    switch (k) {
      case 0:
        layers.density = DecodeFloat32(*bytes);
        break;
      case 1:
        layers.shelter = DecodeFloat32(*bytes);
        break;
      case 2:
        layers.terrain = DecodeFloat32(*bytes);
        break;
      default:
        layers.nofly = *std::move(bytes);
        break;
    }
  }
  absl::StatusOr<std::shared_ptr<const RiskMap>> map = RiskMap::Create(
      std::move(header), std::move(layers), params.glide_ratio, params.glide_clearance_m);
  if (!map.ok()) return InBundle(dir, map.status());
  return map;
}

absl::StatusOr<std::vector<std::shared_ptr<const RiskMap>>> LoadMapDirectory(
    const std::string& dir, const ModelParams& params) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    return absl::NotFoundError(absl::StrCat("maps directory '", dir, "' not found"));
  }
  std::vector<fs::path> bundles;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code entry_ec;
    // A name starting with a dot is hidden, and is what an interrupted
    // WriteMapBundleAtomically leaves: possibly a complete copy of a bundle
    // that is also there under its own name.
    if (it->path().filename().string().starts_with('.')) continue;
    if (it->is_directory(entry_ec) &&
        fs::is_regular_file(it->path() / bundle::kManifestName, entry_ec)) {
      bundles.push_back(it->path());
    }
  }
  if (ec) {
    return absl::UnavailableError(
        absl::StrCat("cannot list maps directory '", dir, "': ", ec.message()));
  }
  std::sort(bundles.begin(), bundles.end(),
            [](const fs::path& a, const fs::path& b) { return a.filename() < b.filename(); });

  std::vector<std::shared_ptr<const RiskMap>> maps;
  std::map<std::string, std::string> bundle_of_name;
  for (const fs::path& bundle : bundles) {
    absl::StatusOr<std::shared_ptr<const RiskMap>> map = LoadMapBundle(bundle.string(), params);
    if (!map.ok()) return map.status();
    auto [it, inserted] = bundle_of_name.emplace((*map)->name(), bundle.string());
    if (!inserted) {
      return absl::InvalidArgumentError(absl::StrCat("maps directory '", dir, "': bundles '",
                                                     it->second, "' and '", bundle.string(),
                                                     "' both hold map '", (*map)->name(), "'"));
    }
    maps.push_back(*std::move(map));
  }
  return maps;
}

}  // namespace riskplan
