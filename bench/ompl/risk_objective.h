// riskplan's admissibility and trajectory risk as OMPL's validity checkers and
// optimisation objective, for the OMPL peer benchmark. Every class here works
// on states of DubinsAirplaneSpace, and an edge from s1 to s2 is the
// Dubins-airplane manoeuvre flown from s1 to s2: exactly the piece
// EvaluateTrajectory builds between two consecutive waypoints.
#ifndef RISKPLAN_BENCH_OMPL_RISK_OBJECTIVE_H_
#define RISKPLAN_BENCH_OMPL_RISK_OBJECTIVE_H_

#include <cstdint>
#include <utility>
#include <vector>

#include "core/flight/trajectory.h"
#include "core/risk/risk_model.h"
#include "ompl/base/MotionValidator.h"
#include "ompl/base/OptimizationObjective.h"
#include "ompl/base/SpaceInformation.h"
#include "ompl/base/StateValidityChecker.h"

namespace riskplan::bench {

// The piece-risk rule (core/flight/piece_risk.h) of the manoeuvre from `a`
// to `b`: the same samples and sum as EvaluateTrajectory's.
PieceRisk EdgeRule(const RiskModel& model, const Pose& a, const Pose& b);

// A state is valid when its configuration is admissible (spec section 6).
class RiskValidityChecker final : public ompl::base::StateValidityChecker {
 public:
  RiskValidityChecker(const ompl::base::SpaceInformationPtr& si, const RiskModel& model)
      : ompl::base::StateValidityChecker(si), model_(model) {}
  bool isValid(const ompl::base::State* state) const override;

 private:
  const RiskModel& model_;
};

// A motion is valid when both ends and every midpoint of spec section 4 are
// admissible: the samples of isAdmissible (spec section 6), the same check
// RISK_RRT_STAR makes before it evaluates an edge.
class RiskMotionValidator final : public ompl::base::MotionValidator {
 public:
  RiskMotionValidator(const ompl::base::SpaceInformationPtr& si, const RiskModel& model)
      : ompl::base::MotionValidator(si), model_(model) {}
  bool checkMotion(const ompl::base::State* s1, const ompl::base::State* s2) const override;
  // `last_valid.first`, when not null, receives the last admissible sample
  // before the first violation and `last_valid.second` its arc fraction.
  bool checkMotion(const ompl::base::State* s1, const ompl::base::State* s2,
                   std::pair<ompl::base::State*, double>& last_valid) const override;

 private:
  const RiskModel& model_;
};

// The trajectory risk of spec section 4 as an OMPL cost (expected casualties
// per flight; smaller is better, costs add).
// - motionCost(s1, s2) solves the manoeuvre s1 -> s2 once and returns the
//   piece risk lambda * sum M(q_k) * ds / v over its midpoints, with the same
//   samples, order of additions and formula as EvaluateTrajectory, so a path's
//   cost is bit for bit the risk EvaluateTrajectory gives its waypoints. An
//   edge with an inadmissible midpoint costs infinity and is not evaluated
//   (its motion is invalid anyway; RISK_RRT_STAR does the same).
// - stateCost is 0 (risk lives on motions only).
// - Heuristics: h = 0 both as cost-to-go and as motionCostHeuristic. It is
//   admissible because M(q) >= 0 and lambda > 0, so no risk is negative; no
//   larger bound holds in general (M is exactly 0 over empty ground).
// - Not symmetric: the risk of s1 -> s2 is not that of s2 -> s1.
// Thread-compatible (the counters are not synchronised).
class RiskObjective final : public ompl::base::OptimizationObjective {
 public:
  RiskObjective(const ompl::base::SpaceInformationPtr& si, const RiskModel& model);

  ompl::base::Cost stateCost(const ompl::base::State* s) const override;
  ompl::base::Cost motionCost(const ompl::base::State* s1,
                              const ompl::base::State* s2) const override;
  ompl::base::Cost motionCostHeuristic(const ompl::base::State* s1,
                                       const ompl::base::State* s2) const override;
  bool isSymmetric() const override { return false; }

  // Configuration risks computed so far, and motionCost calls.
  uint64_t configurations_evaluated() const { return configurations_; }
  uint64_t edges_evaluated() const { return edges_; }

 private:
  const RiskModel& model_;
  mutable uint64_t configurations_ = 0;
  mutable uint64_t edges_ = 0;
};

}  // namespace riskplan::bench

#endif  // RISKPLAN_BENCH_OMPL_RISK_OBJECTIVE_H_
