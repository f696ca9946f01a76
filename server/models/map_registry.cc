#include "server/models/map_registry.h"

#include <utility>

#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "core/map/map_bundle.h"

namespace riskplan::server {

absl::StatusOr<std::unique_ptr<MapRegistry>> MapRegistry::LoadDirectory(const std::string& dir) {
  absl::StatusOr<std::vector<std::shared_ptr<const RiskMap>>> maps = LoadMapDirectory(dir);
  if (!maps.ok()) {
    return absl::Status(maps.status().code(),
                        absl::StrFormat("maps directory '%s': %s", dir, maps.status().message()));
  }
  // A server with nothing to serve is a deployment mistake: refuse to start
  // rather than answer every request with NOT_FOUND.
  if (maps->empty()) {
    return absl::NotFoundError(absl::StrFormat(
        "maps directory '%s' holds no map bundle (no sub-directory with a manifest.json)", dir));
  }
  return FromMaps(*std::move(maps));
}

absl::StatusOr<std::unique_ptr<MapRegistry>> MapRegistry::DemoCity(const DemoCityOptions& options) {
  absl::StatusOr<std::shared_ptr<const RiskMap>> map = MakeDemoCity(options);
  if (!map.ok()) return map.status();
  return FromMaps({*std::move(map)});
}

absl::StatusOr<std::unique_ptr<MapRegistry>> MapRegistry::FromMaps(
    std::vector<std::shared_ptr<const RiskMap>> maps) {
  if (maps.empty()) return absl::InvalidArgumentError("no maps to serve");
  std::unique_ptr<MapRegistry> registry(new MapRegistry);
  for (std::shared_ptr<const RiskMap>& map : maps) {
    const std::string name = map->name();
    // A geo-reference the loader passed but PROJ cannot use (a latitude of
    // 95) would make every WGS84 answer wrong: refused at start-up.
    if (map->header().geo.has_value()) {
      absl::StatusOr<geo::GeoFrame> frame = geo::FrameOfMap(map->header());
      if (!frame.ok()) {
        return absl::InvalidArgumentError(
            absl::StrFormat("map '%s': %s", name, frame.status().message()));
      }
      registry->frames_[name] = std::make_shared<const geo::GeoFrame>(*std::move(frame));
    }
    if (!registry->by_name_.emplace(name, std::move(map)).second) {
      return absl::InvalidArgumentError(absl::StrFormat("two maps are called '%s'", name));
    }
  }
  // by_name_ is ordered: ListMaps and error messages list the maps in the
  // same order whatever the order of the directory or the arguments.
  for (const auto& [name, map] : registry->by_name_) registry->sorted_.push_back(map);
  return registry;
}

std::shared_ptr<const RiskMap> MapRegistry::Find(std::string_view name) const {
  auto it = by_name_.find(name);
  return it == by_name_.end() ? nullptr : it->second;
}

std::shared_ptr<const geo::GeoFrame> MapRegistry::Frame(std::string_view name) const {
  auto it = frames_.find(name);
  return it == frames_.end() ? nullptr : it->second;
}

std::string MapRegistry::NameList() const {
  std::vector<std::string> names;
  for (const auto& [name, map] : by_name_) names.push_back(name);
  return absl::StrJoin(names, ", ");
}

size_t MapRegistry::MemoryBytes() const {
  size_t bytes = 0;
  for (const auto& map : sorted_) bytes += map->MemoryBytes();
  return bytes;
}

}  // namespace riskplan::server
