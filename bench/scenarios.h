// The fixed scenario set of riskplan's planner tests and benchmarks:
// start and goal pairs on demo-city.
#ifndef RISKPLAN_BENCH_SCENARIOS_H_
#define RISKPLAN_BENCH_SCENARIOS_H_

#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include "core/base/geometry.h"
#include "core/risk/risk_model.h"

namespace riskplan::bench {

// A pose at (x, y) with heading theta, at `fraction` of the admissible
// altitude band of its cell (0: safe altitude, 1: ceiling); nullopt when the
// cell is not flyable.
inline std::optional<Pose> FlyablePose(const RiskModel& model, double x, double y, double theta,
                                       double fraction = 0.5) {
  int i = 0;
  int j = 0;
  if (!model.map().CellOf(x, y, &i, &j) || model.map().nofly(i, j)) return std::nullopt;
  const double low = model.SafeAltitude(i, j);
  const double high = model.map().terrain(i, j) + model.params().max_agl_m;
  if (!(low < high)) return std::nullopt;
  Pose p{x, y, low + fraction * (high - low), theta};
  if (model.CheckConfiguration(p) != ViolationKind::kNone) return std::nullopt;
  return p;
}

// FlyablePose at (x, y) or, failing that, at the nearest point of a 25 m
// lattice within 1 km that is flyable.
inline std::optional<Pose> FindFlyablePose(const RiskModel& model, double x, double y,
                                           double theta) {
  for (int ring = 0; ring <= 40; ++ring) {
    for (int dy = -ring; dy <= ring; ++dy) {
      for (int dx = -ring; dx <= ring; ++dx) {
        if (std::max(std::abs(dx), std::abs(dy)) != ring) continue;
        if (auto p = FlyablePose(model, x + 25.0 * dx, y + 25.0 * dy, theta)) return p;
      }
    }
  }
  return std::nullopt;
}

struct Scenario {
  const char* name;
  Pose start;
  Pose goal;
  bool crosses_centre;
};

// The fixed scenario set used by the planner tests and benchmarks: 24 start and
// goal pairs on demo-city; half of them cross the dense centre.
inline std::vector<Scenario> DemoCityScenarios(const RiskModel& model) {
  struct Raw {
    const char* name;
    double x0, y0, th0, x1, y1, th1;
    bool centre;
  };
  const double pi = 3.14159265358979323846;
  const Raw raw[] = {
      // Across the centre (about 4000, 4000).
      {"west-east", 1000, 4000, 0, 7000, 4000, 0, true},
      {"east-west", 7000, 4200, pi, 1000, 3800, pi, true},
      {"south-north", 4000, 1000, pi / 2, 4000, 7000, pi / 2, true},
      {"north-south", 4200, 7000, 3 * pi / 2, 3800, 1000, 3 * pi / 2, true},
      {"sw-ne", 1200, 1200, pi / 4, 6800, 6800, pi / 4, true},
      {"ne-sw", 6800, 6800, 5 * pi / 4, 1200, 1200, 5 * pi / 4, true},
      {"se-nw", 6800, 1200, 3 * pi / 4, 1200, 6800, 3 * pi / 4, true},
      {"nw-se", 1200, 6800, 7 * pi / 4, 6800, 1200, 7 * pi / 4, true},
      {"wsw-ene", 1000, 3000, 0.3, 7000, 5000, 0.3, true},
      {"ssw-nne", 3000, 1000, 1.2, 5000, 7000, 1.2, true},
      {"5km-a", 1700, 2300, 0.8, 5700, 5300, 0.8, true},
      {"5km-b", 6300, 2000, 2.2, 2700, 5500, 2.2, true},
      // Shorter hops in the suburbs, some turning back on themselves.
      {"suburb-w", 800, 1500, 1.57, 1500, 6500, 1.57, false},
      {"suburb-e", 7200, 6500, 4.71, 7000, 1500, 4.71, false},
      {"suburb-s", 1500, 800, 0, 6500, 900, 0, false},
      {"suburb-n", 6500, 7200, pi, 1500, 7100, pi, false},
      {"short-u-turn", 2000, 2000, 0, 2300, 2100, pi, false},
      {"short-climb", 6000, 2000, 1.0, 6400, 2600, 1.0, false},
      {"hop-1", 3000, 6000, 0, 5000, 6300, 0.5, false},
      {"hop-2", 2500, 2500, 4.0, 1200, 3500, 2.0, false},
      // Near the no-fly zones and across the centre's edge.
      {"edge-1", 5600, 3000, pi / 2, 5600, 5000, pi / 2, false},
      {"edge-2", 2400, 3200, pi / 2, 2600, 4900, pi / 2, false},
      {"edge-3", 3000, 5600, 0, 5000, 5700, 0, false},
      {"edge-4", 3100, 2400, 0, 5000, 2500, 0, false},
  };
  std::vector<Scenario> out;
  for (const Raw& r : raw) {
    auto s = FindFlyablePose(model, r.x0, r.y0, r.th0);
    auto g = FindFlyablePose(model, r.x1, r.y1, r.th1);
    if (s && g) out.push_back({r.name, *s, *g, r.centre});
  }
  return out;
}

}  // namespace riskplan::bench

#endif  // RISKPLAN_BENCH_SCENARIOS_H_
