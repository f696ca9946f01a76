// CoarseRiskRoute: a guide route for RISK_RRT_STAR, found by Dijkstra over a
// coarse grid of configuration risks.
//
// The tree finds the right way around a dense centre only after many
// extensions; a coarse estimate of the risk field gives that choice at once.
// Each coarse cell (side `cell_m`) gets the mean configuration risk M of its
// centre over four headings, low in its flight band; cells whose centre cannot
// be flown (outside, no-fly, empty band) or whose risk is undefined for one of
// the four headings (the impact window reaching past the map, spec version 2)
// are closed. The route is the cheapest
// 8-connected path from the start's cell to the goal's under
// cost = length x (lambda / v) x M (plus a small cost per metre, so that it
// does not wander over empty ground), resampled every `spacing_m` as
// waypoints heading along it. In a wind (spec version 3) the time over a
// step is length / gs(theta) of its direction theta, so a step costs
// length x lambda x M / gs(theta): the route prefers to cross dense ground
// with the wind behind it, as the exact risk does.
//
// The grid depends only on the model and the cell size, so a tree that serves
// several starts (core/planners/shared_goal_tree.h) builds it once
// (CoarseRiskGrid) and asks it for each start's route; CoarseRiskRoute is the
// two in one call.
//
// It is only a heuristic: the planner inserts the waypoints into its tree
// through the ordinary extension (exact risks, exact admissibility), and
// whatever it reports is evaluated exactly as before. Deterministic (no
// random numbers; fixed order of evaluation and of ties).
//
// Header-only so that it is compiled into the planner's own translation unit.
#ifndef RISKPLAN_CORE_PLANNERS_RISK_GUIDE_H_
#define RISKPLAN_CORE_PLANNERS_RISK_GUIDE_H_

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <queue>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/base/wind.h"
#include "core/risk/risk_evaluator.h"
#include "core/risk/risk_model.h"

namespace riskplan {

// The coarse grid of configuration risks of one model and cell size, and
// routes over it. Immutable once built.
class CoarseRiskGrid {
 public:
  // Prices every open coarse cell (side `cell_m`, widened to keep at most 100
  // cells a side) in one risk batch. Errors only from the evaluator.
  static absl::StatusOr<CoarseRiskGrid> Build(const RiskModel& model, double cell_m,
                                              RiskEvaluator* evaluator) {
    CoarseRiskGrid g(model);
    const RiskMap& map = model.map();
    const ModelParams& mp = model.params();
    constexpr double kMaxSide = 100.0;
    // At most kMaxSide cells a side, so that the grid costs a few thousand
    // configuration risks (about 10 ms on one core) whatever the map's size.
    g.cell_m_ = std::max(cell_m, std::max(map.width_m(), map.height_m()) / kMaxSide);
    g.nx_ = std::max(1, static_cast<int>(std::ceil(map.width_m() / g.cell_m_)));
    g.ny_ = std::max(1, static_cast<int>(std::ceil(map.height_m() / g.cell_m_)));
    // Configuration risks of every open cell centre, four headings, one batch.
    std::vector<Pose> poses;
    std::vector<int> open_cells;
    for (int cj = 0; cj < g.ny_; ++cj) {
      for (int ci = 0; ci < g.nx_; ++ci) {
        const auto [x, y] = g.Centre(ci, cj);
        int i = 0;
        int j = 0;
        double z = 0.0;
        if (!map.CellOf(x, y, &i, &j) || !g.Altitude(i, j, &z)) continue;
        open_cells.push_back(cj * g.nx_ + ci);
        for (int h = 0; h < 4; ++h) poses.push_back(Pose{x, y, z, h * 0.5 * kPi});
      }
    }
    std::vector<ConfigurationRisk> risks(poses.size());
    if (!poses.empty()) {
      if (absl::Status s = evaluator->EvaluateBatch(model, poses, risks); !s.ok()) return s;
    }
    g.density_.assign(static_cast<size_t>(g.nx_) * g.ny_, kClosed);  // risk per metre
    // Still air: risk per metre, lambda / v x M. In a wind the time over a
    // metre depends on the direction of travel (spec section 4), so the
    // density is lambda x M per second and Route divides it by the ground
    // speed of each step's direction.
    g.calm_ = model.wind().calm();
    const double per_metre =
        g.calm_ ? mp.failure_rate_per_s / mp.airspeed_mps : mp.failure_rate_per_s;
    double total = 0.0;
    size_t priced = 0;
    for (size_t c = 0; c < open_cells.size(); ++c) {
      // A cell where some heading's impact window reaches past the map is
      // closed: unknown ground is never cheap (spec version 2).
      double sum = 0.0;
      bool defined = true;
      for (int h = 0; h < 4; ++h) {
        defined = defined && risks[4 * c + h].defined;
        sum += risks[4 * c + h].risk;
      }
      if (!defined) continue;
      g.density_[open_cells[c]] = per_metre * 0.25 * sum;
      total += g.density_[open_cells[c]];
      ++priced;
    }
    // A cost per metre of 1 % of the mean: shortest among routes of equal risk.
    g.floor_cost_ = priced == 0 ? 0.0 : 0.01 * total / priced;
    if (!g.calm_) {
      g.floor_cost_ /= mp.airspeed_mps;
      // 1 / gs of the eight steps of the grid, (di, dj) in Route's order.
      const WindTriangle& wind = model.wind();
      for (int dj = -1; dj <= 1; ++dj) {
        for (int di = -1; di <= 1; ++di) {
          g.inverse_ground_speed_[(dj + 1) * 3 + (di + 1)] =
              (di == 0 && dj == 0) ? 0.0 : 1.0 / wind.GroundSpeed(std::atan2(dj, di));
        }
      }
    }
    return g;
  }

  // Interior waypoints of the guide route from `start` to `goal` (neither
  // included), in order from the start, one every `spacing_m` or less; empty
  // when the grid has no route or the two are within one spacing.
  std::vector<Pose> Route(const Pose& start, const Pose& goal, double spacing_m) const {
    const RiskModel& model = *model_;
    const RiskMap& map = model.map();
    const ModelParams& mp = model.params();
    constexpr double kMarginM = 5.0;  // above the highest floor near a waypoint
    const int nx = nx_;
    const int ny = ny_;
    const double cell_m = cell_m_;
    const double floor_cost = floor_cost_;
    std::vector<double> density = density_;
    const auto centre = [&](int ci, int cj) { return Centre(ci, cj); };
    const auto altitude = [&](int i, int j, double* z) { return Altitude(i, j, z); };
    const auto cell_of = [&](const Pose& p) {
      const int ci = ClampedCell(p.x - map.x0(), cell_m, nx);
      const int cj = ClampedCell(p.y - map.y0(), cell_m, ny);
      return cj * nx + ci;
    };
    const int source = cell_of(start);
    const int target = cell_of(goal);
    for (int c : {source, target}) {
      if (density[c] == kClosed) density[c] = 0.0;
    }

    // Dijkstra from the start's cell; ties by cell index.
    constexpr double kInf = std::numeric_limits<double>::infinity();
    std::vector<double> dist(density.size(), kInf);
    std::vector<int> prev(density.size(), -1);
    using Item = std::pair<double, int>;
    std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
    dist[source] = 0.0;
    queue.push({0.0, source});
    while (!queue.empty()) {
      const auto [d, c] = queue.top();
      queue.pop();
      if (d > dist[c]) continue;
      if (c == target) break;
      const int ci = c % nx;
      const int cj = c / nx;
      for (int dj = -1; dj <= 1; ++dj) {
        for (int di = -1; di <= 1; ++di) {
          if (di == 0 && dj == 0) continue;
          const int ni = ci + di;
          const int nj = cj + dj;
          if (ni < 0 || nj < 0 || ni >= nx || nj >= ny) continue;
          const int n = nj * nx + ni;
          if (density[n] == kClosed) continue;
          const double length = cell_m * ((di != 0 && dj != 0) ? std::sqrt(2.0) : 1.0);
          // In a wind: the step's time, length / gs of its direction.
          const double mean = calm_ ? 0.5 * (density[c] + density[n])
                                    : 0.5 * (density[c] + density[n]) *
                                          inverse_ground_speed_[(dj + 1) * 3 + (di + 1)];
          const double nd = d + length * (mean + floor_cost);
          if (nd < dist[n]) {
            dist[n] = nd;
            prev[n] = c;
            queue.push({nd, n});
          }
        }
      }
    }
    std::vector<Pose> out;
    if (!std::isfinite(dist[target])) return out;

    // The route as a polyline: start, the cell centres between, goal.
    std::vector<std::pair<double, double>> line;
    for (int c = prev[target]; c >= 0 && c != source; c = prev[c])
      line.push_back(centre(c % nx, c / nx));
    line.push_back({start.x, start.y});
    std::reverse(line.begin(), line.end());
    line.push_back({goal.x, goal.y});
    std::vector<double> at(line.size(), 0.0);  // arc length
    for (size_t k = 1; k < line.size(); ++k) {
      at[k] = at[k - 1] +
              std::hypot(line[k].first - line[k - 1].first, line[k].second - line[k - 1].second);
    }
    const double length = at.back();
    const int parts = static_cast<int>(std::ceil(length / spacing_m));
    if (parts < 2) return out;
    const auto point_at = [&](double s) {
      s = std::clamp(s, 0.0, length);
      size_t k = std::upper_bound(at.begin(), at.end(), s) - at.begin();
      k = std::clamp<size_t>(k, 1, line.size() - 1);
      const double seg = at[k] - at[k - 1];
      const double f = seg > 0.0 ? (s - at[k - 1]) / seg : 0.0;
      return std::pair<double, double>{
          line[k - 1].first + f * (line[k].first - line[k - 1].first),
          line[k - 1].second + f * (line[k].second - line[k - 1].second)};
    };
    const double ds = length / parts;
    std::vector<std::pair<double, double>> xy;
    xy.push_back({start.x, start.y});
    for (int k = 1; k < parts; ++k) xy.push_back(point_at(k * ds));
    xy.push_back({goal.x, goal.y});
    // Each waypoint's altitude: just above the highest floor (safe altitude)
    // on the straight lines to its two neighbours, so that the manoeuvres
    // between them, close to those lines, keep inside the band.
    const auto band_along = [&](const std::pair<double, double>& a,
                                const std::pair<double, double>& b, double* floor_m,
                                double* ceiling_m) {
      const double d = std::hypot(b.first - a.first, b.second - a.second);
      const int n = std::max(1, static_cast<int>(std::ceil(d / map.res())));
      for (int k = 0; k <= n; ++k) {
        const double f = static_cast<double>(k) / n;
        int i = 0;
        int j = 0;
        if (!map.CellOf(a.first + f * (b.first - a.first), a.second + f * (b.second - a.second), &i,
                        &j)) {
          continue;
        }
        *floor_m = std::max(*floor_m, model.SafeAltitude(i, j));
        *ceiling_m = std::min(*ceiling_m, map.terrain(i, j) + mp.max_agl_m);
      }
    };
    for (int k = 1; k < parts; ++k) {
      const auto [x, y] = xy[k];
      int i = 0;
      int j = 0;
      double z = 0.0;
      if (!map.CellOf(x, y, &i, &j) || !altitude(i, j, &z)) continue;
      double floor_m = -kInf;
      double ceiling_m = kInf;
      band_along(xy[k - 1], xy[k], &floor_m, &ceiling_m);
      band_along(xy[k], xy[k + 1], &floor_m, &ceiling_m);
      const double low = model.SafeAltitude(i, j);
      const double high = map.terrain(i, j) + mp.max_agl_m;
      z = floor_m + kMarginM <= ceiling_m ? floor_m + kMarginM : 0.5 * (floor_m + ceiling_m);
      z = std::clamp(z, low, high);
      const double heading =
          std::atan2(xy[k + 1].second - xy[k - 1].second, xy[k + 1].first - xy[k - 1].first);
      out.push_back(Pose{x, y, z, NormalizeHeading(heading)});
    }
    return out;
  }

 private:
  static constexpr double kClosed = -1.0;

  explicit CoarseRiskGrid(const RiskModel& model) : model_(&model) {}

  std::pair<double, double> Centre(int ci, int cj) const {
    const RiskMap& map = model_->map();
    return {map.x0() + std::min((ci + 0.5) * cell_m_, map.width_m() - 0.5 * map.res()),
            map.y0() + std::min((cj + 0.5) * cell_m_, map.height_m() - 0.5 * map.res())};
  }
  // Low in the band: a lower aircraft falls closer and slower.
  bool Altitude(int i, int j, double* z) const {
    const RiskMap& map = model_->map();
    if (map.nofly(i, j)) return false;
    const double low = model_->SafeAltitude(i, j);
    const double high = map.terrain(i, j) + model_->params().max_agl_m;
    if (!(low <= high)) return false;
    *z = low + std::min(10.0, 0.5 * (high - low));
    return true;
  }

  const RiskModel* model_;  // not owned; must outlive the grid
  double cell_m_ = 0.0;
  int nx_ = 1;
  int ny_ = 1;
  // Still air: risk per metre of each cell; in a wind risk per second
  // (lambda x mean M). kClosed: not flown.
  std::vector<double> density_;
  double floor_cost_ = 0.0;
  bool calm_ = true;
  double inverse_ground_speed_[9] = {};  // 1 / gs of the step (di, dj), in a wind
};

// Interior waypoints of the guide route from `start` to `goal` (neither
// included), in order from the start; empty when the coarse grid has no route
// or the two are within one spacing. Errors only from the evaluator.
inline absl::StatusOr<std::vector<Pose>> CoarseRiskRoute(const RiskModel& model, const Pose& start,
                                                         const Pose& goal, double cell_m,
                                                         double spacing_m,
                                                         RiskEvaluator* evaluator) {
  absl::StatusOr<CoarseRiskGrid> grid = CoarseRiskGrid::Build(model, cell_m, evaluator);
  if (!grid.ok()) return grid.status();
  return grid->Route(start, goal, spacing_m);
}

}  // namespace riskplan

#endif  // RISKPLAN_CORE_PLANNERS_RISK_GUIDE_H_
