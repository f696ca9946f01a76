// Fuzz target: the map-bundle loader (LoadMapBundle, core/map/map_bundle.h),
// from manifest.json to the validated RiskMap with its glide layer.
//
// Input: the text of manifest.json, then any number of files, each
// introduced by a line "%%file NAME":
//
//   {"format": "riskplan-map-bundle", ..., "layers": {...}}
//   %%file density.f32
//   <raw bytes>
//   %%file nofly.u8
//   <raw bytes>
//
// (the separator is "\n%%file ", the name runs to the next newline, and a
// file's bytes run to the next separator). The files are written into a
// scratch directory and the loader reads the bundle from there, exactly as
// riskplan-server and riskplan-tool do. A name that is not a plain file name
// is skipped. A bundle that loads must be written back by
// WriteMapBundleAtomically (what riskplan-tool write-map and import use) and
// load again bit for bit (docs/map-bundle.md).
#include <cstdint>
#include <cstring>
#include <fstream>
#include <memory>
#include <string>
#include <string_view>

#include "core/map/map_bundle.h"
#include "core/map/risk_map.h"
#include "fuzz/fuzz_support.h"

namespace riskplan::fuzz {
namespace {

constexpr std::string_view kSeparator = "\n%%file ";

void WriteFile(const std::filesystem::path& path, std::string_view bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

bool PlainName(std::string_view name) {
  return !name.empty() && name.size() <= 100 && name != "." && name != ".." &&
         name != "manifest.json" && name.find_first_of(std::string_view("/\\\0", 3)) ==
                                        std::string_view::npos;
}

// Writes the input's manifest and files into `dir`.
void WriteBundle(std::string_view input, const std::filesystem::path& dir) {
  size_t end = input.find(kSeparator);
  WriteFile(dir / "manifest.json", input.substr(0, end));
  while (end != std::string_view::npos) {
    const size_t name_start = end + kSeparator.size();
    const size_t name_end = input.find('\n', name_start);
    if (name_end == std::string_view::npos) return;
    const std::string_view name = input.substr(name_start, name_end - name_start);
    end = input.find(kSeparator, name_end + 1);
    const std::string_view bytes =
        input.substr(name_end + 1, end == std::string_view::npos ? end : end - name_end - 1);
    if (PlainName(name)) WriteFile(dir / std::string(name), bytes);
  }
}

template <typename T>
bool SameBits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

bool SameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// Everything a bundle carries, compared bit for bit.
bool SameBundle(const RiskMap& a, const RiskMap& b) {
  const MapHeader& ha = a.header();
  const MapHeader& hb = b.header();
  if (ha.name != hb.name || !SameBits(ha.x0, hb.x0) || !SameBits(ha.y0, hb.y0) ||
      !SameBits(ha.res, hb.res) || ha.nx != hb.nx || ha.ny != hb.ny ||
      ha.provenance != hb.provenance || ha.geo.has_value() != hb.geo.has_value()) {
    return false;
  }
  if (ha.geo.has_value() &&
      (!SameBits(ha.geo->origin_lat_deg, hb.geo->origin_lat_deg) ||
       !SameBits(ha.geo->origin_lon_deg, hb.geo->origin_lon_deg) || ha.geo->crs != hb.geo->crs)) {
    return false;
  }
  const MapLayers& la = a.layers();
  const MapLayers& lb = b.layers();
  if (!SameBits(la.density, lb.density) || !SameBits(la.shelter, lb.shelter) ||
      !SameBits(la.terrain, lb.terrain) || la.nofly != lb.nofly ||
      la.landing_sites.size() != lb.landing_sites.size()) {
    return false;
  }
  for (size_t k = 0; k < la.landing_sites.size(); ++k) {
    const LandingSite& sa = la.landing_sites[k];
    const LandingSite& sb = lb.landing_sites[k];
    if (sa.name != sb.name || sa.i != sb.i || sa.j != sb.j) return false;
  }
  return true;
}

}  // namespace
}  // namespace riskplan::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace riskplan;
  static const fuzz::ScratchDir scratch;
  const std::filesystem::path in_dir = scratch.path() / "in";
  const std::filesystem::path out_dir = scratch.path() / "out";
  scratch.Clear();
  std::filesystem::create_directory(in_dir);
  fuzz::WriteBundle(std::string_view(reinterpret_cast<const char*>(data), size), in_dir);

  absl::StatusOr<std::shared_ptr<const RiskMap>> map = LoadMapBundle(in_dir.string());
  if (!map.ok()) {
    // Every refusal names what is wrong.
    if (map.status().message().empty()) fuzz::Fail("a refused bundle without a message");
    return 0;
  }
  if (absl::Status s = WriteMapBundleAtomically(**map, out_dir.string()); !s.ok()) {
    fuzz::Fail(s.ToString());
  }
  absl::StatusOr<std::shared_ptr<const RiskMap>> again = LoadMapBundle(out_dir.string());
  if (!again.ok()) fuzz::Fail(again.status().ToString());
  if (!fuzz::SameBundle(**map, **again)) fuzz::Fail("a written bundle loads back different");
  return 0;
}
