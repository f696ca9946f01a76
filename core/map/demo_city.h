// demo-city: riskplan's built-in procedural map, the default when a server is
// given no maps directory. Deterministic: the same options give the same map,
// bit for bit, on every machine.
#ifndef RISKPLAN_CORE_MAP_DEMO_CITY_H_
#define RISKPLAN_CORE_MAP_DEMO_CITY_H_

#include <cstdint>
#include <memory>

#include "absl/status/statusor.h"
#include "core/base/model_params.h"
#include "core/map/risk_map.h"

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
//
// The default map (8 km at 5 m, 1600 x 1600 cells, origin (0, 0)):
// - density: about 0.05 people/m^2 in downtown blocks around the centre
//   (4000, 4000), falling to 0.002-0.005 in the suburbs (2-3 km out); a ragged
//   city limit at about 3 km (+-0.6 km); farmland (1e-4 to 3e-4) and woods
//   (2e-5) outside; parks about 3e-4, fields 3e-5.
// - shelter: downtown 6-9, residential 4-7, industrial 8-10, roads 1-2, parks
//   and farmland 0-1, woods 3-5.
// - roads: arterials 20 m wide every 500 m (on x or y = multiples of 500 m,
//   also outside the city), streets 10 m wide every 125 m inside the city
//   (left out when cells are coarser than a quarter of that spacing).
// - terrain: a basin at about 105-140 m AMSL, a range to the north-west up to
//   about 295 m, a lower hill to the north-east (about 200 m), the airfield
//   levelled at 112 m.
// - no-fly: airport, hospital, stadium (see DemoCityLandmarks).
// - landing sites: one park ("park-N", inside the city) or field ("field-N",
//   outside) per square kilometre on a jittered grid, clear of no-fly zones,
//   plus "central-park": 65 sites; with the default ModelParams more than 99%
//   of the cells outside no-fly zones are flyable (SafeAltitude(min_agl) <=
//   terrain + max_agl), about 98.8% already at 100 m above terrain.
// Takes about 0.8 s (half of it the glide Dijkstra) at -O2 on one core.
// The grid has n x n cells, n = round(size_m / res_m). Errors:
// InvalidArgument for a non-finite or non-positive size_m or res_m, or more
// than kMaxMapSide cells per side or kMaxMapCells in all (checked before any
// allocation); otherwise those of RiskMap::Create() for params.glide_ratio and
// params.glide_clearance_m.
absl::StatusOr<std::shared_ptr<const RiskMap>> MakeDemoCity(const DemoCityOptions& options = {},
                                                            const ModelParams& params = {});

// A rectangle [x0, x1) x [y0, y1) in map metres.
struct DemoCityBox {
  double x0 = 0.0, y0 = 0.0, x1 = 0.0, y1 = 0.0;
};

struct DemoCityPoint {
  double x = 0.0, y = 0.0;
};

// Start and goal for tests and examples.
struct DemoCityRoute {
  const char* name;
  DemoCityPoint start;
  DemoCityPoint goal;
};

// The fixed places of demo-city, in map metres for the given options: they
// scale with size_m and do not depend on the seed. At the default size:
//   centre (4000, 4000); hospital [4300, 4450] x [4200, 4350];
//   stadium [2500, 2800] x [3600, 3850]; airport [5400, 6600] x [1500, 2100]
//   with its runway along y ~ 1800.
struct DemoCityLandmarks {
  DemoCityPoint centre;       // density peak, downtown
  DemoCityBox airport;        // no-fly
  DemoCityBox runway;         // inside the airport
  DemoCityBox hospital;       // no-fly, 150 m square near the centre
  DemoCityBox stadium;        // no-fly
  DemoCityBox industrial[2];  // east and south-west industrial zones
  DemoCityBox central_park;   // holds landing site "central-park"
  // Suburb-to-suburb routes on opposite sides of the centre ("west-east",
  // "southwest-northeast", "south-north"), ends in residential blocks off the
  // arterials. With the default seed, size and ModelParams, both ends and
  // every point of the straight segment between them are outside no-fly zones
  // and have SafeAltitude(min_agl = 30) <= terrain + 100, and the straight
  // segment crosses downtown (so a risk-aware plan should bend around it).
  DemoCityRoute routes[3];
};

DemoCityLandmarks GetDemoCityLandmarks(const DemoCityOptions& options = {});

}  // namespace riskplan

#endif  // RISKPLAN_CORE_MAP_DEMO_CITY_H_
