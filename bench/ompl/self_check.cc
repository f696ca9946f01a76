#include "bench/ompl/self_check.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "bench/ompl/grid_nearest_neighbors.h"
#include "bench/ompl/risk_objective.h"
#include "bench/ompl/risk_state_space.h"
#include "bench/scenarios.h"
#include "core/base/random.h"
#include "core/flight/dubins.h"
#include "core/flight/trajectory.h"
#include "ompl/base/ScopedState.h"
#include "ompl/datastructures/NearestNeighborsLinear.h"

namespace riskplan::bench {
namespace {

namespace ob = ompl::base;

// A random admissible pose at mid-band, or nullopt.
std::optional<Pose> RandomPose(const RiskModel& model, Rng* rng) {
  const RiskMap& map = model.map();
  for (int attempt = 0; attempt < 100; ++attempt) {
    const double x = map.x0() + rng->Uniform() * map.width_m();
    const double y = map.y0() + rng->Uniform() * map.height_m();
    if (auto p = FlyablePose(model, x, y, rng->Uniform() * kTwoPi, rng->Uniform())) return p;
  }
  return std::nullopt;
}

// A pose 100-1500 m from `from`, admissible, or nullopt.
std::optional<Pose> NearbyPose(const RiskModel& model, const Pose& from, Rng* rng) {
  for (int attempt = 0; attempt < 100; ++attempt) {
    const double r = 100.0 + 1400.0 * rng->Uniform();
    const double a = rng->Uniform() * kTwoPi;
    if (auto p = FlyablePose(model, from.x + r * std::cos(a), from.y + r * std::sin(a),
                             rng->Uniform() * kTwoPi, rng->Uniform())) {
      return p;
    }
  }
  return std::nullopt;
}

struct Item {
  ob::State* state = nullptr;
};

}  // namespace

bool RunSelfCheck(std::shared_ptr<const RiskModel> model, int edges) {
  const RiskModel& m = *model;
  auto space = std::make_shared<DubinsAirplaneSpace>(model);
  auto si = std::make_shared<ob::SpaceInformation>(space);
  si->setStateValidityChecker(std::make_shared<RiskValidityChecker>(si, m));
  auto validator = std::make_shared<RiskMotionValidator>(si, m);
  si->setMotionValidator(validator);
  si->setup();
  RiskObjective objective(si, m);
  Rng rng(7);
  bool ok = true;

  // 1. Edge costs and admissibility against EvaluateTrajectory.
  int exact = 0;
  int admissible = 0;
  int validator_agrees = 0;
  int tried = 0;
  int path_exact = 0;
  int paths = 0;
  double worst_interpolation_m = 0.0;
  double worst_round_trip = 0.0;
  ob::ScopedState<> a(space);
  ob::ScopedState<> b(space);
  ob::ScopedState<> c(space);
  while (tried < edges) {
    auto p = RandomPose(m, &rng);
    if (!p) continue;
    auto q = NearbyPose(m, *p, &rng);
    auto r = q ? NearbyPose(m, *q, &rng) : std::nullopt;
    if (!q || !r) continue;
    ++tried;
    DubinsAirplaneSpace::FromPose(*p, a.get());
    DubinsAirplaneSpace::FromPose(*q, b.get());
    DubinsAirplaneSpace::FromPose(*r, c.get());
    const Pose pa = DubinsAirplaneSpace::ToPose(a.get());
    const Pose pb = DubinsAirplaneSpace::ToPose(b.get());
    const Pose pc = DubinsAirplaneSpace::ToPose(c.get());
    worst_round_trip =
        std::max({worst_round_trip, std::abs(pa.theta - p->theta),
                  std::abs(pa.x - p->x) + std::abs(pa.y - p->y) + std::abs(pa.z - p->z)});
    const std::vector<Pose> two = {pa, pb};
    auto pieces = PiecesFromWaypoints(two, m.params());
    if (!pieces.ok()) {
      std::printf("self-check: PiecesFromWaypoints failed: %s\n",
                  std::string(pieces.status().message()).c_str());
      return false;
    }
    auto eval = EvaluateTrajectory(m, *pieces);
    if (!eval.ok()) {
      std::printf("self-check: EvaluateTrajectory failed: %s\n",
                  std::string(eval.status().message()).c_str());
      return false;
    }
    const bool valid = si->checkMotion(a.get(), b.get());
    if (valid == eval->admissible) ++validator_agrees;
    if (eval->admissible) {
      ++admissible;
      if (objective.motionCost(a.get(), b.get()).value() == eval->risk) ++exact;
      // Three waypoints: the summed cost, in path order, against the total.
      const std::vector<Pose> three = {pa, pb, pc};
      auto pieces3 = PiecesFromWaypoints(three, m.params());
      auto eval3 = pieces3.ok() ? EvaluateTrajectory(m, *pieces3)
                                : absl::StatusOr<TrajectoryEvaluation>(pieces3.status());
      if (eval3.ok() && eval3->admissible) {
        ++paths;
        const ob::Cost sum =
            objective.combineCosts(objective.combineCosts(objective.identityCost(),
                                                          objective.motionCost(a.get(), b.get())),
                                   objective.motionCost(b.get(), c.get()));
        if (sum.value() == eval3->risk) ++path_exact;
      }
    }
    // Interpolation: the pose at t along the manoeuvre.
    const ModelParams& mp = m.params();
    const DubinsAirplanePath path(pa, pb, mp.GroundTurnRadius(), mp.GroundClimbAngle());
    for (double t : {0.0, 0.25, 0.5, 1.0}) {
      space->interpolate(a.get(), b.get(), t, c.get());
      const Pose got = DubinsAirplaneSpace::ToPose(c.get());
      const Pose want = path.PoseAt(t * path.Length());
      worst_interpolation_m = std::max(worst_interpolation_m,
                                       std::hypot(got.x - want.x, got.y - want.y, got.z - want.z));
    }
  }
  std::printf("self-check: %d random edges, %d admissible\n", tried, admissible);
  std::printf("self-check: motion validator agrees with EvaluateTrajectory on %d/%d edges\n",
              validator_agrees, tried);
  std::printf("self-check: motionCost == EvaluateTrajectory piece risk, bit for bit: %d/%d\n",
              exact, admissible);
  std::printf("self-check: two-edge path cost == EvaluateTrajectory total, bit for bit: %d/%d\n",
              path_exact, paths);
  std::printf("self-check: pose round trip worst error %.3g, interpolation worst error %.3g m\n",
              worst_round_trip, worst_interpolation_m);
  // Every heading gives a state inside OMPL's bounds (SO2: [-pi, pi)).
  int in_bounds = 0;
  const std::vector<double> headings = {0.0,     1.0,
                                        kPi / 2, std::nextafter(kPi, 0.0),
                                        kPi,     std::nextafter(kPi, 4.0),
                                        4.0,     std::nextafter(kTwoPi, 0.0)};
  const Pose centre = FindFlyablePose(m, 4000.0, 4000.0, 0.0).value_or(Pose{});
  for (double heading : headings) {
    Pose p = centre;
    p.theta = heading;
    DubinsAirplaneSpace::FromPose(p, a.get());
    if (si->satisfiesBounds(a.get()) &&
        DubinsAirplaneSpace::ToPose(a.get()).theta == NormalizeHeading(heading)) {
      ++in_bounds;
    }
  }
  std::printf("self-check: states inside OMPL's bounds with their heading kept: %d/%zu\n",
              in_bounds, headings.size());
  // Risk model version 2: a pose 20 m inside the map's edge, heading out of
  // the map, has an impact window reaching past the map
  // (IMPACT_OUTSIDE_MAP): the validity checker rejects it, and an edge from
  // a flyable pose inland to it is rejected by the motion validator and
  // costs infinity.
  int border = 0;
  int border_rejected = 0;
  {
    const RiskMap& bm = m.map();
    const double x1 = bm.x0() + bm.width_m();
    const double y1 = bm.y0() + bm.height_m();
    for (int k = 1; k < 20; ++k) {
      const double u = k / 20.0;
      const double along_x = bm.x0() + u * bm.width_m();
      const double along_y = bm.y0() + u * bm.height_m();
      // West, east, south, north edges, heading out of the map.
      const Pose edge_poses[] = {{bm.x0() + 20.0, along_y, 0.0, kPi},
                                 {x1 - 20.0, along_y, 0.0, 0.0},
                                 {along_x, bm.y0() + 20.0, 0.0, -kPi / 2},
                                 {along_x, y1 - 20.0, 0.0, kPi / 2}};
      for (const Pose& e : edge_poses) {
        int i = 0;
        int j = 0;
        if (!bm.CellOf(e.x, e.y, &i, &j) || bm.nofly(i, j)) continue;
        Pose p = e;
        const double low = m.SafeAltitude(i, j);
        const double high = bm.terrain(i, j) + m.params().max_agl_m;
        if (!(low < high)) continue;
        p.z = 0.5 * (low + high);
        if (m.CheckConfiguration(p) != ViolationKind::kImpactOutsideMap) continue;
        // A flyable pose 1 km inland, heading to the edge.
        const double ix = std::clamp(p.x, bm.x0() + 1000.0, x1 - 1000.0);
        const double iy = std::clamp(p.y, bm.y0() + 1000.0, y1 - 1000.0);
        auto inland = FindFlyablePose(m, ix, iy, p.theta);
        if (!inland) continue;
        ++border;
        DubinsAirplaneSpace::FromPose(p, a.get());
        DubinsAirplaneSpace::FromPose(*inland, b.get());
        if (!si->isValid(a.get()) && !si->checkMotion(b.get(), a.get()) &&
            std::isinf(objective.motionCost(b.get(), a.get()).value())) {
          ++border_rejected;
        }
      }
    }
  }
  std::printf(
      "self-check: IMPACT_OUTSIDE_MAP poses by the edges rejected (state, motion, cost = inf): "
      "%d/%d\n",
      border_rejected, border);
  ok = ok && validator_agrees == tried && exact == admissible && path_exact == paths &&
       worst_round_trip < 1e-12 && worst_interpolation_m < 1e-9 &&
       in_bounds == static_cast<int>(headings.size()) && border > 0 && border_rejected == border;

  // 2. GridNearestNeighbors against NearestNeighborsLinear.
  const RiskMap& map = m.map();
  GridNeighborsLayout() = GridLayout{map.x0(), map.y0(), map.width_m(), map.height_m(), 200.0};
  GridNearestNeighbors<Item*> grid;
  ompl::NearestNeighborsLinear<Item*> linear;
  auto distance = [&](Item* const& x, Item* const& y) {
    return space->distance(x->state, y->state);
  };
  grid.setDistanceFunction(distance);
  linear.setDistanceFunction(distance);
  std::vector<Item> items(3000);
  for (Item& it : items) {
    it.state = space->allocState();
    auto p = RandomPose(m, &rng);
    DubinsAirplaneSpace::FromPose(p.value_or(Pose{}), it.state);
  }
  int queries = 0;
  int same = 0;
  for (size_t n = 0; n < items.size(); ++n) {
    grid.add(&items[n]);
    linear.add(&items[n]);
    if (n % 300 != 299) continue;
    for (size_t k : {size_t{1}, size_t{8}, size_t{30}}) {
      for (int qn = 0; qn < 5; ++qn) {
        Item* query = &items[rng.Below(n + 1)];
        std::vector<Item*> g;
        std::vector<Item*> l;
        grid.nearestK(query, k, g);
        linear.nearestK(query, k, l);
        ++queries;
        bool equal = g.size() == l.size();
        for (size_t i = 0; equal && i < g.size(); ++i) {
          equal = distance(g[i], query) == distance(l[i], query);
        }
        grid.nearestR(query, 600.0, g);
        linear.nearestR(query, 600.0, l);
        equal = equal && g.size() == l.size();
        for (size_t i = 0; equal && i < g.size(); ++i) {
          equal = distance(g[i], query) == distance(l[i], query);
        }
        if (equal) ++same;
      }
    }
  }
  // Removal keeps the answers equal.
  for (size_t n = 0; n < items.size(); n += 3) {
    grid.remove(&items[n]);
    linear.remove(&items[n]);
  }
  for (int qn = 0; qn < 20; ++qn) {
    Item* query = &items[rng.Below(items.size())];
    std::vector<Item*> g;
    std::vector<Item*> l;
    grid.nearestK(query, 10, g);
    linear.nearestK(query, 10, l);
    ++queries;
    bool equal = g.size() == l.size() && grid.size() == linear.size();
    for (size_t i = 0; equal && i < g.size(); ++i) {
      equal = distance(g[i], query) == distance(l[i], query);
    }
    if (equal) ++same;
  }
  std::printf("self-check: grid nearest neighbours == linear scan on %d/%d queries\n", same,
              queries);
  ok = ok && same == queries;
  for (Item& it : items) space->freeState(it.state);
  std::printf("self-check: %s\n", ok ? "PASS" : "FAIL");
  return ok;
}

}  // namespace riskplan::bench
