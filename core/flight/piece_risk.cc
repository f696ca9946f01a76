#include "core/flight/piece_risk.h"

#include <algorithm>
#include <cmath>
#include <span>

namespace riskplan {

int64_t PartCount(double length_m, double step_m) {
  RISKPLAN_DCHECK(step_m > 0.0);
  // A length that cannot be measured (NaN: coordinates so far apart that the
  // geometry overflowed) cannot be sampled either: over any bound.
  if (std::isnan(length_m)) return kMaxPartCount;
  if (!(length_m > 0.0)) return 0;
  const double parts = std::ceil(length_m / step_m);
  // Converting a double at or past 2^63 to int64 is undefined: saturate first.
  if (!(parts < static_cast<double>(kMaxPartCount))) return kMaxPartCount;
  return static_cast<int64_t>(parts);
}

PieceRisk::PieceRisk(const TrajectoryPiece& piece, double step_m, const ModelParams& params)
    : piece_(piece),
      parts_(PartCount(piece.Length(), step_m)),
      part_length_m_(parts_ > 0 ? piece.Length() / static_cast<double>(parts_) : 0.0),
      wind_(params),
      per_metre_(params.Calm() ? params.failure_rate_per_s / params.airspeed_mps
                               : params.failure_rate_per_s) {
  RISKPLAN_DCHECK(parts_ < kMaxPartCount);
}

void PieceRisk::AppendMidpoints(int64_t begin, int64_t end, std::vector<Pose>* out) const {
  RISKPLAN_DCHECK(0 <= begin && begin <= end && end <= parts_);
  // Midpoint(k) for each k, the arcs in batches (a manoeuvre's turns are
  // computed once per batch rather than once per midpoint).
  constexpr int64_t kBatch = 256;
  double arcs[kBatch];
  for (int64_t first = begin; first < end; first += kBatch) {
    const int64_t n = std::min(kBatch, end - first);
    for (int64_t k = 0; k < n; ++k) arcs[k] = MidpointArc(first + k);
    const size_t at = out->size();
    out->resize(at + static_cast<size_t>(n));
    piece_.PosesAt(std::span<const double>(arcs, static_cast<size_t>(n)), out->data() + at);
  }
}

Pose PieceRisk::AdmissibilitySample(int64_t i, double* arc_m) const {
  RISKPLAN_DCHECK(i >= 0 && i < admissibility_samples());
  double s;
  Pose q;
  if (i == 0) {
    s = 0.0;
    q = piece_.Start();
  } else if (i <= parts_) {
    s = MidpointArc(i - 1);
    q = piece_.PoseAt(s);
  } else {
    s = piece_.Length();
    q = piece_.End();
  }
  if (arc_m != nullptr) *arc_m = s;
  return q;
}

void AppendMidpoints(const TrajectoryPiece& piece, double step_m, std::vector<Pose>* out) {
  // Only the geometry is used: lambda and v do not matter here.
  const PieceRisk rule(piece, step_m, ModelParams{});
  rule.AppendMidpoints(0, rule.parts(), out);
}

}  // namespace riskplan
