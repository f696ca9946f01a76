// PathRefiner: local improvement of a waypoint trajectory under the exact risk
// (spec section 4), for the anytime RISK_RRT_STAR.
//
// An edit replaces the waypoints strictly between two waypoints `first` and
// `last` of the trajectory by one new waypoint (drawn around the trajectory
// between them, at a random scale) or by none (a shortcut). The new pieces are
// evaluated exactly as EvaluateTrajectory evaluates a piece (same manoeuvre,
// same midpoints, same order of additions), chunk by chunk, each chunk's
// midpoints checked for admissibility (spec section 6) before its risks are
// computed, and the edit is abandoned as soon as an inadmissible midpoint
// appears or the new pieces' partial risk reaches the risk of the pieces they
// would replace (configuration risks are never negative, so it cannot come
// back under). An edit that is returned therefore makes the trajectory
// admissible again and strictly lowers the sum of the pieces it touches; its
// piece risks are bit for bit EvaluateTrajectory's.
//
// Edits only ever need a few hundred configuration risks (two pieces of a few
// hundred metres, usually abandoned early), so many can be tried between tree
// iterations. Deterministic: every random number comes from the Rng given.
//
// Header-only so that it is compiled into the planner's own translation unit.
#ifndef RISKPLAN_CORE_PLANNERS_PATH_REFINER_H_
#define RISKPLAN_CORE_PLANNERS_PATH_REFINER_H_

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/cancellation.h"
#include "core/base/geometry.h"
#include "core/base/random.h"
#include "core/flight/trajectory.h"
#include "core/planners/planner_support.h"
#include "core/risk/risk_evaluator.h"
#include "core/risk/risk_model.h"

namespace riskplan {

class PathRefiner {
 public:
  // The waypoints strictly between `first` and `last` become `waypoint` (when
  // has_waypoint) or nothing.
  struct Edit {
    size_t first = 0;
    size_t last = 0;
    bool has_waypoint = false;
    Pose waypoint;
    double risk_in = 0.0;   // piece first -> waypoint (or first -> last)
    double risk_out = 0.0;  // piece waypoint -> last (0 without a waypoint)
  };

  // `scale_m`: the largest standard deviation of a new waypoint's horizontal
  // offset, m. `chunk`: midpoints generated, checked and evaluated at a time.
  // `stop`: polled between chunks (TryEdit then fails with RunStopped()).
  // `evaluator` and `model` must outlive the refiner.
  PathRefiner(const RiskModel& model, RiskEvaluator* evaluator, double scale_m, int64_t chunk,
              StopCondition stop = {})
      : model_(model),
        evaluator_(evaluator),
        scale_m_(scale_m),
        chunk_(std::max<int64_t>(1, chunk)),
        stop_(stop) {}

  // Replaces the StopCondition polled between chunks (a run whose earliest
  // deadline changes).
  void set_stop(const StopCondition& stop) { stop_ = stop; }

  // Draws one edit of the trajectory `waypoints` (start ... goal, at least 2)
  // whose piece i (waypoints[i] -> waypoints[i + 1]) has the exact risk
  // piece_risks[i], and evaluates it. Returns true and sets *edit when it
  // lowers the risk of the pieces it replaces; false when it does not (or is
  // not admissible). Errors from the evaluator, and RunStopped().
  absl::StatusOr<bool> TryEdit(std::span<const Pose> waypoints, std::span<const double> piece_risks,
                               Rng& rng, Edit* edit) {
    const size_t pieces = piece_risks.size();
    if (pieces == 0) return false;
    // Span: 1 piece (a waypoint inserted), 2 (a waypoint moved, or removed by
    // a shortcut) or 3 (two waypoints replaced by one, or removed).
    const size_t max_span = std::min<size_t>(3, pieces);
    const size_t span = 1 + rng.Below(max_span);
    const size_t first = rng.Below(pieces - span + 1);
    const size_t last = first + span;
    const bool shortcut = span >= 2 && rng.Uniform() < kShortcutShare;
    double old_risk = 0.0;
    for (size_t i = first; i < last; ++i) old_risk += piece_risks[i];
    if (!(old_risk > 0.0)) return false;  // nothing to gain

    const ModelParams& mp = model_.params();
    Edit e;
    e.first = first;
    e.last = last;
    e.has_waypoint = !shortcut;
    if (e.has_waypoint) {
      // Around a point of the current trajectory between the two ends: the
      // waypoint being moved (span 2, half the time), else a point drawn
      // uniformly along the pieces in between.
      Pose base;
      if (span == 2 && rng.Uniform() < 0.5) {
        base = waypoints[first + 1];
      } else {
        std::vector<TrajectoryPiece> between;
        double length = 0.0;
        for (size_t i = first; i < last; ++i) {
          between.push_back(TrajectoryPiece::Manoeuvre(waypoints[i], waypoints[i + 1],
                                                       mp.GroundTurnRadius(), mp.GroundClimbAngle()));
          length += between.back().Length();
        }
        double s = (0.1 + 0.8 * rng.Uniform()) * length;
        base = between.back().End();
        for (const TrajectoryPiece& p : between) {
          if (s <= p.Length()) {
            base = p.PoseAt(s);
            break;
          }
          s -= p.Length();
        }
      }
      // Log-uniform scale between 1/64 and 1 of the largest.
      const double f = std::exp2(-6.0 * rng.Uniform());
      e.waypoint = Pose{base.x + f * scale_m_ * rng.Normal(), base.y + f * scale_m_ * rng.Normal(),
                        base.z + f * kAltitudeScaleM * rng.Normal(),
                        NormalizeHeading(base.theta + f * kHeadingScaleRad * rng.Normal())};
      if (model_.CheckConfiguration(e.waypoint) != ViolationKind::kNone) return false;
    }
    // The new pieces, evaluated against the risk of those they replace.
    const Pose& to_first = e.has_waypoint ? e.waypoint : waypoints[last];
    pieces_[0] =
        TrajectoryPiece::Manoeuvre(waypoints[first], to_first, mp.GroundTurnRadius(), mp.GroundClimbAngle());
    const int count = e.has_waypoint ? 2 : 1;
    if (e.has_waypoint) {
      pieces_[1] = TrajectoryPiece::Manoeuvre(e.waypoint, waypoints[last], mp.GroundTurnRadius(),
                                              mp.GroundClimbAngle());
    }
    double risks[2] = {0.0, 0.0};
    double done_risk = 0.0;  // complete pieces
    for (int p = 0; p < count; ++p) {
      absl::StatusOr<double> r = ExactPieceRisk(pieces_[p], old_risk - done_risk);
      if (!r.ok()) return r.status();
      if (!std::isfinite(*r)) return false;
      risks[p] = *r;
      done_risk += *r;
    }
    e.risk_in = risks[0];
    e.risk_out = risks[1];
    if (!(e.risk_in + e.risk_out < old_risk)) return false;
    *edit = e;
    return true;
  }

 private:
  static constexpr double kShortcutShare = 0.25;
  static constexpr double kAltitudeScaleM = 30.0;
  static constexpr double kHeadingScaleRad = 0.8;

  // The exact piece risk of `piece` (EvaluateTrajectory's), or +inf as soon as
  // a midpoint is inadmissible or the partial risk reaches `limit`.
  absl::StatusOr<double> ExactPieceRisk(const TrajectoryPiece& piece, double limit) {
    const ModelParams& mp = model_.params();
    PieceRisk rule(piece, mp.sample_step_m, mp);
    while (!rule.complete()) {
      if (stop_.Reached()) return RunStopped();
      const int64_t done = rule.added();
      const int64_t end = rule.ChunkEnd(chunk_);
      poses_.clear();
      for (int64_t i = done; i < end; ++i) {
        const Pose q = rule.Midpoint(i);
        if (model_.CheckConfiguration(q) != ViolationKind::kNone) return kInf;
        poses_.push_back(q);
      }
      risks_.resize(poses_.size());
      if (absl::Status s = evaluator_->EvaluateBatch(model_, poses_, risks_); !s.ok()) return s;
      for (size_t k = 0; k < risks_.size(); ++k) rule.Add(risks_[k], poses_[k]);
      if (!(rule.PartialRisk() < limit)) return kInf;
    }
    return rule.Risk();
  }

  static constexpr double kInf = std::numeric_limits<double>::infinity();

  const RiskModel& model_;
  RiskEvaluator* evaluator_;
  const double scale_m_;
  const int64_t chunk_;
  StopCondition stop_;
  TrajectoryPiece pieces_[2];
  std::vector<Pose> poses_;
  std::vector<ConfigurationRisk> risks_;
};

}  // namespace riskplan

#endif  // RISKPLAN_CORE_PLANNERS_PATH_REFINER_H_
