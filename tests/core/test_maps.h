// Small synthetic maps for tests.
#ifndef RISKPLAN_TESTS_CORE_TEST_MAPS_H_
#define RISKPLAN_TESTS_CORE_TEST_MAPS_H_

#include <memory>
#include <string>
#include <vector>

#include "core/map/risk_map.h"
#include "gtest/gtest.h"

namespace riskplan::testing_maps {

// A flat map with uniform layers. Aborts the test on failure.
inline std::shared_ptr<const RiskMap> UniformMap(int nx, int ny, double res, float density,
                                                 float shelter, float terrain,
                                                 std::vector<LandingSite> sites = {},
                                                 std::string name = "uniform") {
  MapHeader header;
  header.name = std::move(name);
  header.res = res;
  header.nx = nx;
  header.ny = ny;
  header.provenance = "test";
  MapLayers layers;
  const size_t n = static_cast<size_t>(nx) * ny;
  layers.density.assign(n, density);
  layers.shelter.assign(n, shelter);
  layers.terrain.assign(n, terrain);
  layers.nofly.assign(n, 0);
  layers.landing_sites = std::move(sites);
  auto map = RiskMap::Create(std::move(header), std::move(layers));
  EXPECT_TRUE(map.ok()) << map.status();
  return map.ok() ? *map : nullptr;
}

}  // namespace riskplan::testing_maps

#endif  // RISKPLAN_TESTS_CORE_TEST_MAPS_H_
