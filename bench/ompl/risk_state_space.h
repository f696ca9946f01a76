// riskplan's problem as an OMPL state space: (x, y, heading) + altitude with
// riskplan's own Dubins-airplane geometry (spec section 5), for the OMPL peer
// benchmark (bench/ompl/ompl_bench.cc). Bench code: built only when OMPL 1.5
// is installed.
//
// Why not OMPL's DubinsStateSpace: in 1.5.2 it aborts through an assertion
// with an absolute tolerance once the map is more than about 8 turning radii
// across (demo-city is 160). The space below derives from SE2 + a real vector
// of one (the altitude) and answers distance and interpolation with
// DubinsAirplanePath, the code riskplan's planner and EvaluateTrajectory use.
#ifndef RISKPLAN_BENCH_OMPL_RISK_STATE_SPACE_H_
#define RISKPLAN_BENCH_OMPL_RISK_STATE_SPACE_H_

#include <memory>

#include "core/base/geometry.h"
#include "core/risk/risk_model.h"
#include "ompl/base/StateSampler.h"
#include "ompl/base/StateSpace.h"

namespace riskplan::bench {

// A compound of SE2 (x, y, yaw) and R^1 (z). Distance is the 3-D length of the
// Dubins-airplane manoeuvre flown *from* the first state *to* the second; it is
// neither symmetric nor a metric (no triangle inequality with spirals), and
// says so, so that OMPL's default nearest-neighbour choice is not GNAT (which
// relies on the triangle inequality). Interpolation at t is the pose at
// t * Length() along that manoeuvre. The default sampler draws like
// RISK_RRT_STAR's uniform samples: x, y and heading uniform, z uniform in the
// admissible band [safe_alt, T + max_agl] of the cell, no-fly cells redrawn.
//
// The model must outlive the space.
class DubinsAirplaneSpace final : public ompl::base::CompoundStateSpace {
 public:
  explicit DubinsAirplaneSpace(std::shared_ptr<const RiskModel> model);

  double distance(const ompl::base::State* from, const ompl::base::State* to) const override;
  void interpolate(const ompl::base::State* from, const ompl::base::State* to, double t,
                   ompl::base::State* state) const override;
  bool hasSymmetricDistance() const override { return false; }
  bool hasSymmetricInterpolate() const override { return false; }
  bool isMetricSpace() const override { return false; }
  ompl::base::StateSamplerPtr allocDefaultStateSampler() const override;

  const RiskModel& model() const { return *model_; }

  // Conversions. OMPL keeps yaw in [-pi, pi); riskplan's headings are in
  // [0, 2 pi). ToPose(FromPose(p)) equals p up to the last bit of theta.
  static Pose ToPose(const ompl::base::State* state);
  static void FromPose(const Pose& pose, ompl::base::State* state);

 private:
  std::shared_ptr<const RiskModel> model_;
};

// The default sampler of DubinsAirplaneSpace (see there). Uses the sampler's
// own ompl::RNG, so OMPL's global seed fixes its sequence.
class AltitudeBandSampler final : public ompl::base::StateSampler {
 public:
  explicit AltitudeBandSampler(const DubinsAirplaneSpace* space);

  void sampleUniform(ompl::base::State* state) override;
  // x and y uniform within `distance` of `near`, heading uniform, z in band.
  void sampleUniformNear(ompl::base::State* state, const ompl::base::State* near,
                         double distance) override;
  // x, y and z Gaussian around `mean` (z clamped into the band), heading
  // Gaussian with std_dev / turn radius.
  void sampleGaussian(ompl::base::State* state, const ompl::base::State* mean,
                      double std_dev) override;

 private:
  // Draws z in the band of (x, y); false when (x, y) is not flyable.
  bool SampleAltitude(double x, double y, double* z);

  const RiskModel& model_;
};

}  // namespace riskplan::bench

#endif  // RISKPLAN_BENCH_OMPL_RISK_STATE_SPACE_H_
