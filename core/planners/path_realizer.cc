#include "core/planners/path_realizer.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include "core/base/check.h"
#include "core/planners/planner_support.h"

namespace riskplan {

bool SegmentTouchesArea(const Point2& a, const Point2& b, const ClosedArea& area) {
  // Liang-Barsky clipping of the segment against the closed rectangle.
  double t0 = 0.0;
  double t1 = 1.0;
  const double dx = b.x - a.x;
  const double dy = b.y - a.y;
  const double p[4] = {-dx, dx, -dy, dy};
  const double q[4] = {a.x - area.x0_m, area.x1_m - a.x, a.y - area.y0_m, area.y1_m - a.y};
  for (int k = 0; k < 4; ++k) {
    if (p[k] == 0.0) {
      if (q[k] < 0.0) return false;
      continue;
    }
    const double t = q[k] / p[k];
    if (p[k] < 0.0) {
      t0 = std::max(t0, t);
    } else {
      t1 = std::min(t1, t);
    }
    if (t0 > t1) return false;
  }
  return true;
}

TrajectoryChecker::TrajectoryChecker(const RiskModel& model, const ObstaclePointSet* points,
                                     double clearance_m, std::vector<ClosedArea> closed_areas)
    : model_(model),
      points_(points != nullptr && points->size() > 0 ? points : nullptr),
      clearance_m_(clearance_m),
      closed_areas_(std::move(closed_areas)) {}

bool TrajectoryChecker::SampleFails(const Pose& q) const {
  return model_.CheckConfiguration(q) != ViolationKind::kNone;
}

bool TrajectoryChecker::ChordFails(const Pose& a, const Pose& b, double margin_m) const {
  const Point2 pa{a.x, a.y};
  const Point2 pb{b.x, b.y};
  if (points_ != nullptr && !points_->SegmentClear(pa, pb, clearance_m_ + margin_m)) return true;
  for (const ClosedArea& area : closed_areas_) {
    if (SegmentTouchesArea(pa, pb, area)) return true;
  }
  return false;
}

int TrajectoryChecker::Violations(const TrajectoryPiece& piece, bool first_only) const {
  const ModelParams& mp = model_.params();
  const bool chords = points_ != nullptr || !closed_areas_.empty();
  const PieceRisk rule(piece, mp.sample_step_m, mp);
  const double ds = rule.part_length_m();
  // A chord of length c on a turn of radius R lies within c^2 / (8 R) of the
  // arc; consecutive samples are at most ds apart along the arc.
  const double margin = piece.is_segment() ? 0.0 : ds * ds / (8.0 * mp.GroundTurnRadius()) + 1e-6;
  int count = 0;
  Pose prev = rule.AdmissibilitySample(0);
  if (SampleFails(prev)) {
    ++count;
    if (first_only) return count;
  }
  for (int64_t i = 1; i < rule.admissibility_samples(); ++i) {
    const Pose q = rule.AdmissibilitySample(i);
    if (SampleFails(q) || (chords && ChordFails(prev, q, margin))) {
      ++count;
      if (first_only) return count;
    }
    prev = q;
  }
  return count;
}

int TrajectoryChecker::Violations(std::span<const Pose> waypoints, bool first_only) const {
  const ModelParams& mp = model_.params();
  int count = 0;
  for (size_t i = 0; i + 1 < waypoints.size(); ++i) {
    count += Violations(TrajectoryPiece::Manoeuvre(waypoints[i], waypoints[i + 1], mp.GroundTurnRadius(),
                                                   mp.GroundClimbAngle()),
                        first_only);
    if (first_only && count > 0) return count;
  }
  return count;
}

double BisectorHeading(const Point2& a, const Point2& b, const Point2& c) {
  const double in_x = b.x - a.x, in_y = b.y - a.y;
  const double out_x = c.x - b.x, out_y = c.y - b.y;
  const bool has_in = in_x != 0.0 || in_y != 0.0;
  const bool has_out = out_x != 0.0 || out_y != 0.0;
  if (!has_in && !has_out) return 0.0;
  if (!has_in) return NormalizeHeading(std::atan2(out_y, out_x));
  if (!has_out) return NormalizeHeading(std::atan2(in_y, in_x));
  const double h_in = std::atan2(in_y, in_x);
  double turn = std::atan2(out_y, out_x) - h_in;
  if (turn > kPi) turn -= kTwoPi;
  if (turn <= -kPi) turn += kTwoPi;
  return NormalizeHeading(h_in + 0.5 * turn);
}

PathRealizer::PathRealizer(const TrajectoryChecker& checker, RealizerOptions options)
    : checker_(checker), model_(checker.model()), options_(options) {}

bool PathRealizer::Profile(const Pose& start, const Pose& goal, const std::vector<Point2>& points,
                           const std::vector<double>& arc, double margin_m, double slope,
                           std::vector<double>* z) const {
  const size_t n = points.size();
  const RiskMap& map = model_.map();
  std::vector<double> lo(n), hi(n), pref(n);
  for (size_t k = 0; k < n; ++k) {
    int i = 0, j = 0;
    double low = 0.0, high = 0.0;
    if (!map.CellOf(points[k].x, points[k].y, &i, &j) || !CellBand(model_, i, j, &low, &high)) {
      return false;
    }
    pref[k] = options_.flight_altitude_m > 0.0 ? options_.flight_altitude_m : 0.5 * (low + high);
    if (high - low > 2.0 * margin_m) {
      low += margin_m;
      high -= margin_m;
    } else {
      low = high = 0.5 * (low + high);
    }
    lo[k] = low;
    hi[k] = high;
  }
  lo[0] = hi[0] = start.z;
  lo[n - 1] = hi[n - 1] = goal.z;
  // Forward: the altitudes reachable from the start; backward: those from
  // which the goal is reachable. Their intersection holds every altitude a
  // feasible profile can pass through at each point.
  std::vector<double> f_lo(n), f_hi(n), b_lo(n), b_hi(n);
  f_lo[0] = f_hi[0] = start.z;
  for (size_t k = 1; k < n; ++k) {
    const double climb = slope * (arc[k] - arc[k - 1]);
    f_lo[k] = std::max(lo[k], f_lo[k - 1] - climb);
    f_hi[k] = std::min(hi[k], f_hi[k - 1] + climb);
    if (f_lo[k] > f_hi[k]) return false;
  }
  b_lo[n - 1] = b_hi[n - 1] = goal.z;
  for (size_t k = n - 1; k-- > 0;) {
    const double climb = slope * (arc[k + 1] - arc[k]);
    b_lo[k] = std::max(lo[k], b_lo[k + 1] - climb);
    b_hi[k] = std::min(hi[k], b_hi[k + 1] + climb);
    if (b_lo[k] > b_hi[k]) return false;
  }
  z->assign(n, 0.0);
  (*z)[0] = start.z;
  for (size_t k = 1; k < n; ++k) {
    const double climb = slope * (arc[k] - arc[k - 1]);
    const double low = std::max({f_lo[k], b_lo[k], (*z)[k - 1] - climb});
    const double high = std::min({f_hi[k], b_hi[k], (*z)[k - 1] + climb});
    // low <= high up to rounding: the previous altitude lies in the feasible set.
    (*z)[k] = low <= high ? std::clamp(pref[k], low, high) : 0.5 * (low + high);
  }
  (*z)[n - 1] = goal.z;
  return true;
}

std::optional<std::vector<Pose>> PathRealizer::Realize(const Pose& start, const Pose& goal,
                                                       std::span<const Point2> path) const {
  RISKPLAN_DCHECK(path.size() >= 2);
  if (path.size() < 2) return std::nullopt;
  const ModelParams& mp = model_.params();
  const double step = model_.map().res();
  // The direct manoeuvre first: when it passes, no path point is needed.
  const TrajectoryPiece direct =
      TrajectoryPiece::Manoeuvre(start, goal, mp.GroundTurnRadius(), mp.GroundClimbAngle());
  if (checker_.Violations(direct, /*first_only=*/true) == 0) {
    return std::vector<Pose>{start, goal};
  }

  // 1. Resample at least every cell, dropping repeated points.
  std::vector<Point2> points;
  std::vector<double> arc;
  points.push_back({start.x, start.y});
  arc.push_back(0.0);
  for (size_t k = 0; k + 1 < path.size(); ++k) {
    const Point2 a = k == 0 ? Point2{start.x, start.y} : path[k];
    const Point2 b = k + 2 == path.size() ? Point2{goal.x, goal.y} : path[k + 1];
    const double len = std::hypot(b.x - a.x, b.y - a.y);
    if (len == 0.0) continue;
    const int parts = std::max(1, static_cast<int>(std::ceil(len / step)));
    for (int m = 1; m <= parts; ++m) {
      const double f = static_cast<double>(m) / parts;
      points.push_back({a.x + f * (b.x - a.x), a.y + f * (b.y - a.y)});
      arc.push_back(arc.back() + len / parts);
    }
  }
  if (points.size() < 3) return std::nullopt;  // nothing between start and goal to split at
  const size_t n = points.size();

  // 2. Altitude profile: with the margins first, then at the band's edges and
  // the full climb limit.
  std::vector<double> z;
  const double tan_climb = std::tan(mp.GroundClimbAngle());
  if (!Profile(start, goal, points, arc, options_.band_margin_m,
               options_.slope_fraction * tan_climb, &z) &&
      !Profile(start, goal, points, arc, 0.0, tan_climb, &z)) {
    return std::nullopt;
  }

  // 3. Waypoints, top-down.
  std::vector<size_t> chosen = {0, n - 1};
  std::map<std::tuple<size_t, size_t, double, double>, bool> passed;
  auto heading = [&](size_t w) {
    if (w == 0) return start.theta;
    if (w + 1 == chosen.size()) return goal.theta;
    return BisectorHeading(points[chosen[w - 1]], points[chosen[w]], points[chosen[w + 1]]);
  };
  auto pose_at = [&](size_t w) {
    if (w == 0) return start;
    if (w + 1 == chosen.size()) return goal;
    const size_t k = chosen[w];
    return Pose{points[k].x, points[k].y, z[k], heading(w)};
  };
  const double straight_m = std::max(2.0 * step, 0.1 * mp.GroundTurnRadius());
  while (true) {
    std::vector<Pose> poses;
    for (size_t w = 0; w < chosen.size(); ++w) poses.push_back(pose_at(w));
    std::vector<size_t> next = {chosen[0]};
    bool all_pass = true;
    for (size_t w = 0; w + 1 < chosen.size(); ++w) {
      const size_t a = chosen[w];
      const size_t b = chosen[w + 1];
      const auto key = std::make_tuple(a, b, poses[w].theta, poses[w + 1].theta);
      auto it = passed.find(key);
      bool ok = false;
      if (it != passed.end()) {
        ok = it->second;
      } else {
        const TrajectoryPiece piece =
            TrajectoryPiece::Manoeuvre(poses[w], poses[w + 1], mp.GroundTurnRadius(), mp.GroundClimbAngle());
        ok = checker_.Violations(piece, /*first_only=*/true) == 0;
        passed.emplace(key, ok);
      }
      if (!ok) {
        all_pass = false;
        if (b - a < 2) return std::nullopt;
        // Split at the point farthest from the chord, or mid-arc when the path
        // between is nearly straight (a split there would not change much).
        const Point2& pa = points[a];
        const Point2& pb = points[b];
        double worst = -1.0;
        size_t split = a + 1;
        for (size_t k = a + 1; k < b; ++k) {
          const double d2 = SquaredDistanceToSegment(points[k], pa, pb);
          if (d2 > worst) {
            worst = d2;
            split = k;
          }
        }
        if (worst < straight_m * straight_m) {
          const double mid = 0.5 * (arc[a] + arc[b]);
          split = static_cast<size_t>(std::lower_bound(arc.begin() + a, arc.begin() + b, mid) -
                                      arc.begin());
          split = std::clamp(split, a + 1, b - 1);
        }
        next.push_back(split);
      }
      next.push_back(b);
    }
    if (all_pass) return poses;
    chosen = std::move(next);
    if (chosen.size() > options_.max_waypoints) return std::nullopt;
  }
}

}  // namespace riskplan
