// MapRegistry: the maps a server serves, loaded once at start-up.
//
// Maps are immutable and shared (shared_ptr<const RiskMap>); the registry
// itself never changes after construction, so every const method is
// thread-safe without locking.
#ifndef RISKPLAN_SERVER_MODELS_MAP_REGISTRY_H_
#define RISKPLAN_SERVER_MODELS_MAP_REGISTRY_H_

#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/map/demo_city.h"
#include "core/map/risk_map.h"
#include "geo/geo_frame.h"

namespace riskplan::server {

class MapRegistry {
 public:
  // Loads every bundle in the sub-directories of `dir` (LoadMapDirectory).
  // Fails, naming the bundle and the fault, on the first bad bundle, and when
  // the directory holds no bundle at all.
  static absl::StatusOr<std::unique_ptr<MapRegistry>> LoadDirectory(const std::string& dir);

  // The built-in demo-city alone.
  static absl::StatusOr<std::unique_ptr<MapRegistry>> DemoCity(const DemoCityOptions& options = {});

  // The given maps. InvalidArgument when two share a name, there are none,
  // or a map's geo-reference is not a WGS84 position (GeoFrame::Create).
  static absl::StatusOr<std::unique_ptr<MapRegistry>> FromMaps(
      std::vector<std::shared_ptr<const RiskMap>> maps);

  // The map called `name`, or null.
  std::shared_ptr<const RiskMap> Find(std::string_view name) const;

  // The WGS84 frame of the map called `name` (geo/geo_frame.h), or null when
  // it has no geo-reference (or no such map is served).
  std::shared_ptr<const geo::GeoFrame> Frame(std::string_view name) const;

  // Every map, sorted by name.
  const std::vector<std::shared_ptr<const RiskMap>>& maps() const { return sorted_; }

  // Names joined by ", " (for error messages).
  std::string NameList() const;

  // Bytes held by all maps' layers.
  size_t MemoryBytes() const;

 private:
  MapRegistry() = default;

  std::map<std::string, std::shared_ptr<const RiskMap>, std::less<>> by_name_;
  std::map<std::string, std::shared_ptr<const geo::GeoFrame>, std::less<>> frames_;
  std::vector<std::shared_ptr<const RiskMap>> sorted_;
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_MODELS_MAP_REGISTRY_H_
