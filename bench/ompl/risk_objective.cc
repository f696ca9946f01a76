#include "bench/ompl/risk_objective.h"

#include "bench/ompl/risk_state_space.h"

namespace riskplan::bench {
namespace {

namespace ob = ompl::base;

bool Admissible(const RiskModel& model, const Pose& q) {
  return model.CheckConfiguration(q) == ViolationKind::kNone;
}

}  // namespace

PieceRisk EdgeRule(const RiskModel& model, const Pose& a, const Pose& b) {
  const ModelParams& p = model.params();
  return PieceRisk(TrajectoryPiece::Manoeuvre(a, b, p.GroundTurnRadius(), p.GroundClimbAngle()),
                   p.sample_step_m, p);
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
  const PieceRisk edge = EdgeRule(model_, a, b);
  const double length = edge.piece().Length();
  // The admissibility samples in order of arc length: start, midpoints, end.
  Pose previous = a;
  double previous_s = 0.0;
  bool ok = true;
  for (int64_t i = 0; i < edge.admissibility_samples(); ++i) {
    double s = 0.0;
    const Pose q = edge.AdmissibilitySample(i, &s);
    if (!Admissible(model_, q)) {
      ok = false;
      break;
    }
    previous = q;
    previous_s = s;
  }
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
  PieceRisk edge =
      EdgeRule(model_, DubinsAirplaneSpace::ToPose(s1), DubinsAirplaneSpace::ToPose(s2));
  std::vector<Pose> midpoints;
  edge.AppendMidpoints(0, edge.parts(), &midpoints);
  // Admissibility first (cheap): an inadmissible edge is never evaluated.
  for (const Pose& q : midpoints) {
    if (!Admissible(model_, q)) return infiniteCost();
  }
  for (const Pose& q : midpoints) edge.Add(model_.Evaluate(q), q);
  configurations_ += midpoints.size();
  // Exactly EvaluateTrajectory's piece risk.
  return ob::Cost(edge.Risk());
}

}  // namespace riskplan::bench
