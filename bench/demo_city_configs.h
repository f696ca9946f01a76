// The two access patterns every kernel benchmark measures on demo-city, 100 m
// above ground (issue 5): samples 5 m apart along straight 1 km legs in random
// directions, as the planner asks for them, and configurations uniform over
// the map. Deterministic (fixed seeds), so every benchmark sees the same ones.
#ifndef RISKPLAN_BENCH_DEMO_CITY_CONFIGS_H_
#define RISKPLAN_BENCH_DEMO_CITY_CONFIGS_H_

#include <cmath>
#include <vector>

#include "core/base/geometry.h"
#include "core/base/random.h"
#include "core/risk/risk_model.h"

namespace riskplan::bench {

inline Pose At100mAgl(const RiskModel& model, double x, double y, double theta) {
  int i = 0;
  int j = 0;
  model.map().CellOf(x, y, &i, &j);
  return Pose{x, y, model.map().terrain(i, j) + 100.0, theta};
}

// n samples of 200-sample legs (1 km), 5 m apart.
inline std::vector<Pose> AlongTrajectories(const RiskModel& model, size_t n) {
  Rng rng(1);
  std::vector<Pose> out;
  while (out.size() < n) {
    const double theta = rng.Uniform() * kTwoPi;
    double x = 1000.0 + rng.Uniform() * 6000.0;
    double y = 1000.0 + rng.Uniform() * 6000.0;
    for (int k = 0; k < 200 && out.size() < n; ++k) {
      out.push_back(At100mAgl(model, x, y, theta));
      x += 5.0 * std::cos(theta);
      y += 5.0 * std::sin(theta);
    }
  }
  return out;
}

// n configurations uniform over the map (200 m from its edges).
inline std::vector<Pose> RandomConfigurations(const RiskModel& model, size_t n) {
  Rng rng(2);
  std::vector<Pose> out;
  for (size_t k = 0; k < n; ++k) {
    out.push_back(At100mAgl(model, 200.0 + rng.Uniform() * 7600.0, 200.0 + rng.Uniform() * 7600.0,
                            rng.Uniform() * kTwoPi));
  }
  return out;
}

}  // namespace riskplan::bench

#endif  // RISKPLAN_BENCH_DEMO_CITY_CONFIGS_H_
