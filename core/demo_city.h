// demo-city: riskplan's built-in procedural map, the default when a server is
// given no maps directory. Deterministic: the same options give the same map,
// bit for bit, on every machine.
#ifndef RISKPLAN_CORE_DEMO_CITY_H_
#define RISKPLAN_CORE_DEMO_CITY_H_

#include <cstdint>
#include <memory>

#include "absl/status/statusor.h"
#include "core/model_params.h"
#include "core/risk_map.h"

namespace riskplan {

inline constexpr uint64_t kDemoCitySeed = 20231;

struct DemoCityOptions {
  uint64_t seed = kDemoCitySeed;
  double size_m = 8000.0;  // square, side in metres
  double res_m = 5.0;      // cell side
};

// Builds demo-city (name "demo-city"): about 8 km x 8 km at 5 m cells with a
// dense centre and suburbs, roads, parks and open fields (the landing sites),
// hills, industrial and residential shelter, and no-fly zones (an airport, a
// hospital). Smaller sizes keep the same layout scaled down (for tests).
absl::StatusOr<std::shared_ptr<const RiskMap>> MakeDemoCity(const DemoCityOptions& options = {},
                                                            const ModelParams& params = {});

}  // namespace riskplan

#endif  // RISKPLAN_CORE_DEMO_CITY_H_
