// PieceRisk: the piece-risk rule of spec sections 4 and 6, written once.
//
// A piece of 3-D length L is cut into K = ceil(L / step) equal parts of length
// ds = L / K. M is taken at the midpoint of part k, at arc length (k + 1/2) ds
// from the piece's start, for k = 0 ... K-1; the M are summed in that order
// (an undefined M adds nothing), and the piece risk is
//   R_piece = lambda * sum(M * ds / gs(theta_k)),
// computed as (lambda / v) * sum(M) * ds in still air (version 2, bit for bit)
// and as lambda * sum(M / gs(theta_k)) * ds in wind (spec version 3, section
// 4: gs the ground speed of the midpoint's track heading). The flight time of
// the piece is L / v in still air and sum(ds / gs(theta_k)) in wind.
// Admissibility is checked at the piece's start, its K midpoints and its end,
// in order of arc length (spec section 6).
//
// Every part of riskplan that samples a piece or sums its risk goes through
// this class: EvaluateTrajectory, RISK_RRT_STAR's candidate edges, the path
// refiner, the GENETIC fitness, the path realiser's checks and two-tier
// feasibility. Their risks therefore agree bit for bit: a planner's reported
// risk is exactly EvaluateRisk's for the same trajectory.
//
// Usage: generate the midpoints (Midpoint(k)), evaluate them in any batches,
// then Add() their risks in order of k. PartialRisk() after any prefix is a
// lower bound of the piece risk (M >= 0, so the sum only grows): a planner
// drops a candidate edge as soon as its partial risk loses. Once every
// midpoint is added, Risk() is the piece risk.
//
// Thread-compatible: a value type, copyable and movable.
#ifndef RISKPLAN_CORE_FLIGHT_PIECE_RISK_H_
#define RISKPLAN_CORE_FLIGHT_PIECE_RISK_H_

#include <cstdint>
#include <limits>
#include <vector>

#include "core/base/check.h"
#include "core/base/geometry.h"
#include "core/base/model_params.h"
#include "core/base/wind.h"
#include "core/flight/trajectory_piece.h"
#include "core/risk/risk_model.h"

namespace riskplan {

// K = ceil(length_m / step_m): 0 for a piece of length 0, and counted in 64
// bits. A count that does not fit (length_m / step_m >= 2^62, infinite or
// NaN) saturates at kMaxPartCount, so a caller that bounds the number of
// samples before generating them sees a count over any bound it can set.
// REQUIRES: step_m > 0.
inline constexpr int64_t kMaxPartCount = int64_t{1} << 62;
int64_t PartCount(double length_m, double step_m);

class PieceRisk {
 public:
  // The rule for `piece` sampled every `step_m` (the model's sample_step_m
  // for risk and admissibility; GENETIC's fitness may use a coarser one),
  // with lambda and v from `params`. REQUIRES: step_m > 0, and
  // PartCount(piece.Length(), step_m) < kMaxPartCount.
  PieceRisk(const TrajectoryPiece& piece, double step_m, const ModelParams& params);

  const TrajectoryPiece& piece() const { return piece_; }
  // K, the number of parts and of midpoints.
  int64_t parts() const { return parts_; }
  // ds = L / K (0 when K = 0).
  double part_length_m() const { return part_length_m_; }

  // Arc length of midpoint k from the piece's start: (k + 1/2) ds.
  // REQUIRES: 0 <= k < parts().
  double MidpointArc(int64_t k) const {
    RISKPLAN_DCHECK(k >= 0 && k < parts_);
    return (static_cast<double>(k) + 0.5) * part_length_m_;
  }
  // The configuration at midpoint k. REQUIRES: 0 <= k < parts().
  Pose Midpoint(int64_t k) const { return piece_.PoseAt(MidpointArc(k)); }
  // Appends midpoints [begin, end) to `out`, in order.
  // REQUIRES: 0 <= begin <= end <= parts().
  void AppendMidpoints(int64_t begin, int64_t end, std::vector<Pose>* out) const;

  // The admissibility samples of spec section 6, in order of arc length:
  // sample 0 is the start, samples 1 ... K the midpoints, sample K + 1 the end.
  int64_t admissibility_samples() const { return parts_ + 2; }
  // Sample i and, when `arc_m` is not null, its arc length from the piece's
  // start. REQUIRES: 0 <= i < admissibility_samples().
  Pose AdmissibilitySample(int64_t i, double* arc_m = nullptr) const;

  // Adds M of the next midpoint, number added(), which is `q` (Midpoint(
  // added())): its track heading sets the ground speed in wind. An undefined
  // M adds no risk (but its time).
  // REQUIRES: !complete().
  void Add(const ConfigurationRisk& m, const Pose& q) {
    RISKPLAN_DCHECK(added_ < parts_);
    if (wind_.calm()) {
      if (m.defined) sum_ += m.risk;
    } else {
      // The straight parts of a manoeuvre repeat their heading: their ground
      // speed is computed once (the same number).
      if (!(q.theta == last_theta_)) {
        last_theta_ = q.theta;
        last_inv_speed_ = 1.0 / wind_.GroundSpeed(q.theta);
      }
      const double inv_speed = last_inv_speed_;
      if (m.defined) sum_ += m.risk * inv_speed;
      inv_speed_sum_ += inv_speed;
    }
    ++added_;
  }
  // Midpoints added so far.
  int64_t added() const { return added_; }
  // End of the next run of at most `chunk` midpoints after those added,
  // min(added() + chunk, parts()): a planner that evaluates an edge chunk by
  // chunk generates midpoints [added(), ChunkEnd(chunk)) next.
  // REQUIRES: chunk >= 1.
  int64_t ChunkEnd(int64_t chunk) const {
    RISKPLAN_DCHECK(chunk >= 1);
    return parts_ - added_ > chunk ? added_ + chunk : parts_;
  }
  bool complete() const { return added_ == parts_; }

  // lambda * sum(M ds / gs) over the midpoints added so far: never more than
  // the piece risk, and equal to it once complete().
  double PartialRisk() const { return per_metre_ * sum_ * part_length_m_; }
  // The piece risk. REQUIRES: complete().
  double Risk() const {
    RISKPLAN_DCHECK(complete());
    return PartialRisk();
  }
  // The piece's flight time (spec section 4): L / v in still air, else
  // sum(ds / gs(theta_k)) over its midpoints. REQUIRES: complete().
  double FlightTimeS() const {
    RISKPLAN_DCHECK(complete());
    if (wind_.calm()) return piece_.Length() / wind_.airspeed_mps();
    return inv_speed_sum_ * part_length_m_;
  }

 private:
  TrajectoryPiece piece_;
  int64_t parts_ = 0;
  double part_length_m_ = 0.0;
  WindTriangle wind_;
  double per_metre_ = 0.0;  // lambda / v in still air: failures per metre; lambda in wind
  double sum_ = 0.0;        // sum of M (M / gs in wind) over midpoints [0, added_), in order
  double inv_speed_sum_ = 0.0;  // sum of 1 / gs over midpoints [0, added_), in wind
  int64_t added_ = 0;
  // The last midpoint's track heading and 1 / gs of it (in wind).
  double last_theta_ = std::numeric_limits<double>::quiet_NaN();
  double last_inv_speed_ = 0.0;
};

// Appends every midpoint of `piece` sampled every `step_m` to `out`
// (PieceRisk's midpoints; for callers that need only the samples).
void AppendMidpoints(const TrajectoryPiece& piece, double step_m, std::vector<Pose>* out);

}  // namespace riskplan

#endif  // RISKPLAN_CORE_FLIGHT_PIECE_RISK_H_
