// What the bundle loader (map_bundle.cc) and writer (map_bundle_writer.cc)
// share: the format's fixed names and values, its four raster layers, and the
// checksum of a layer file. docs/map-bundle.md is the normative description of
// everything below. Internal to core/map: the API is map_bundle.h.
#ifndef RISKPLAN_CORE_MAP_MAP_BUNDLE_FORMAT_H_
#define RISKPLAN_CORE_MAP_MAP_BUNDLE_FORMAT_H_

#include <openssl/evp.h>

#include <cstddef>
#include <cstdint>
#include <string>

namespace riskplan::bundle {

inline constexpr char kFormatName[] = "riskplan-map-bundle";
inline constexpr int64_t kFormatVersion = 1;
inline constexpr char kManifestName[] = "manifest.json";
inline constexpr char kByteOrder[] = "little";
inline constexpr char kRowOrder[] = "south_to_north";

// The four raster layers, in the order they are checked and written.
struct LayerInfo {
  const char* name;
  const char* dtype;
  const char* default_file;
  size_t bytes_per_cell;
};
inline constexpr LayerInfo kLayers[4] = {
    {"density", "float32", "density.f32", 4},
    {"shelter", "float32", "shelter.f32", 4},
    {"terrain", "float32", "terrain.f32", 4},
    {"nofly", "uint8", "nofly.u8", 1},
};

// The lower-case hex SHA-256 of `size` bytes at `data`; empty if OpenSSL fails.
inline std::string Sha256Hex(const uint8_t* data, size_t size) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  if (EVP_Digest(data, size, digest, &length, EVP_sha256(), nullptr) != 1) return "";
  static constexpr char kHex[] = "0123456789abcdef";
  std::string hex;
  hex.reserve(2 * length);
  for (unsigned int k = 0; k < length; ++k) {
    hex.push_back(kHex[digest[k] >> 4]);
    hex.push_back(kHex[digest[k] & 15]);
  }
  return hex;
}

}  // namespace riskplan::bundle

#endif  // RISKPLAN_CORE_MAP_MAP_BUNDLE_FORMAT_H_
