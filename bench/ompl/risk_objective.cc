#include "bench/ompl/risk_objective.h"

#include "bench/ompl/risk_state_space.h"

namespace riskplan::bench {
namespace {

namespace ob = ompl::base;

bool Admissible(const RiskModel& model, const Pose& q) {
  return model.CheckConfiguration(q) == ViolationKind::kNone;
}

}  // namespace

EdgeSamples SampleEdge(const RiskModel& model, const Pose& a, const Pose& b) {
  const ModelParams& p = model.params();
  EdgeSamples edge{TrajectoryPiece::Manoeuvre(a, b, p.turn_radius_m, p.max_climb_rad), {}, 0.0};
  // The same parts as EvaluateTrajectory: K = ceil(L / d_step), midpoints
  // at (i + 0.5) * L / K.
  const int parts = PartCount(edge.piece.Length(), p.sample_step_m);
  edge.ds_m = parts > 0 ? edge.piece.Length() / parts : 0.0;
  edge.midpoints.reserve(parts);
  for (int i = 0; i < parts; ++i)
    edge.midpoints.push_back(edge.piece.PoseAt((i + 0.5) * edge.ds_m));
  return edge;
}

bool RiskValidityChecker::isValid(const ob::State* state) const {
  return Admissible(model_, DubinsAirplaneSpace::ToPose(state));
}

bool RiskMotionValidator::checkMotion(const ob::State* s1, const ob::State* s2) const {
  std::pair<ob::State*, double> unused{nullptr, 0.0};
  return checkMotion(s1, s2, unused);
}

bool RiskMotionValidator::checkMotion(const ob::State* s1, const ob::State* s2,
                                      std::pair<ob::State*, double>& last_valid) const {
  const Pose a = DubinsAirplaneSpace::ToPose(s1);
  const Pose b = DubinsAirplaneSpace::ToPose(s2);
  const EdgeSamples edge = SampleEdge(model_, a, b);
  const double length = edge.piece.Length();
  // In order of arc length: start, midpoints, end.
  Pose previous = a;
  double previous_s = 0.0;
  bool ok = Admissible(model_, a);
  for (size_t i = 0; ok && i < edge.midpoints.size(); ++i) {
    if (!Admissible(model_, edge.midpoints[i])) {
      ok = false;
      break;
    }
    previous = edge.midpoints[i];
    previous_s = (i + 0.5) * edge.ds_m;
  }
  if (ok) ok = Admissible(model_, b);
  if (ok) {
    ++valid_;
    return true;
  }
  ++invalid_;
  if (last_valid.first != nullptr) DubinsAirplaneSpace::FromPose(previous, last_valid.first);
  last_valid.second = length > 0.0 ? previous_s / length : 0.0;
  return false;
}

RiskObjective::RiskObjective(const ob::SpaceInformationPtr& si, const RiskModel& model)
    : ob::OptimizationObjective(si), model_(model) {
  description_ = "riskplan trajectory risk (spec section 4)";
  // h = 0: admissible, since no risk is negative (see the header).
  setCostToGoHeuristic([](const ob::State*, const ob::Goal*) { return ob::Cost(0.0); });
}

ob::Cost RiskObjective::stateCost(const ob::State* /*s*/) const { return identityCost(); }

ob::Cost RiskObjective::motionCostHeuristic(const ob::State* /*s1*/,
                                            const ob::State* /*s2*/) const {
  return identityCost();
}

ob::Cost RiskObjective::motionCost(const ob::State* s1, const ob::State* s2) const {
  ++edges_;
  const EdgeSamples edge =
      SampleEdge(model_, DubinsAirplaneSpace::ToPose(s1), DubinsAirplaneSpace::ToPose(s2));
  // Admissibility first (cheap): an inadmissible edge is never evaluated.
  for (const Pose& q : edge.midpoints) {
    if (!Admissible(model_, q)) return infiniteCost();
  }
  double sum = 0.0;
  for (const Pose& q : edge.midpoints) {
    const ConfigurationRisk r = model_.Evaluate(q);
    if (r.defined) sum += r.risk;
  }
  configurations_ += edge.midpoints.size();
  const ModelParams& p = model_.params();
  // Exactly EvaluateTrajectory's piece risk: (lambda / v) * sum * ds.
  const double per_metre = p.failure_rate_per_s / p.airspeed_mps;
  return ob::Cost(per_metre * sum * edge.ds_m);
}

}  // namespace riskplan::bench
