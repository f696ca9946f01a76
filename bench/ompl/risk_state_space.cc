#include "bench/ompl/risk_state_space.h"

#include <algorithm>
#include <limits>

#include "core/flight/dubins.h"
#include "ompl/base/spaces/RealVectorStateSpace.h"
#include "ompl/base/spaces/SE2StateSpace.h"

namespace riskplan::bench {
namespace {

namespace ob = ompl::base;

// Lowest and highest altitude any admissible configuration can have: the
// bounds of the altitude subspace (its measure enters RRT*'s radius rule).
void AltitudeBounds(const RiskModel& model, double* low, double* high) {
  const RiskMap& map = model.map();
  *low = std::numeric_limits<double>::infinity();
  *high = -std::numeric_limits<double>::infinity();
  for (int j = 0; j < map.ny(); ++j) {
    for (int i = 0; i < map.nx(); ++i) {
      if (map.nofly(i, j)) continue;
      const double safe = model.SafeAltitude(i, j);
      const double ceiling = map.terrain(i, j) + model.params().max_agl_m;
      if (!(safe <= ceiling)) continue;
      *low = std::min(*low, safe);
      *high = std::max(*high, ceiling);
    }
  }
}

}  // namespace

DubinsAirplaneSpace::DubinsAirplaneSpace(std::shared_ptr<const RiskModel> model)
    : model_(std::move(model)) {
  setName("DubinsAirplane");
  const RiskMap& map = model_->map();
  auto se2 = std::make_shared<ob::SE2StateSpace>();
  ob::RealVectorBounds xy(2);
  xy.setLow(0, map.x0());
  xy.setHigh(0, map.x0() + map.width_m());
  xy.setLow(1, map.y0());
  xy.setHigh(1, map.y0() + map.height_m());
  se2->setBounds(xy);
  auto altitude = std::make_shared<ob::RealVectorStateSpace>(1);
  double low = 0.0;
  double high = 0.0;
  AltitudeBounds(*model_, &low, &high);
  altitude->setBounds(low, high);
  addSubspace(se2, 1.0);
  addSubspace(altitude, 1.0);
  lock();
}

Pose DubinsAirplaneSpace::ToPose(const ob::State* state) {
  const auto* compound = state->as<ob::CompoundState>();
  const auto* se2 = compound->as<ob::SE2StateSpace::StateType>(0);
  const auto* z = compound->as<ob::RealVectorStateSpace::StateType>(1);
  return Pose{se2->getX(), se2->getY(), z->values[0], NormalizeHeading(se2->getYaw())};
}

void DubinsAirplaneSpace::FromPose(const Pose& pose, ob::State* state) {
  auto* compound = state->as<ob::CompoundState>();
  auto* se2 = compound->as<ob::SE2StateSpace::StateType>(0);
  se2->setXY(pose.x, pose.y);
  const double theta = NormalizeHeading(pose.theta);
  // SO2's bounds are [-pi, pi): a heading of exactly pi must become -pi, or
  // OMPL rejects the state as out of bounds (BIT* then drops such a goal).
  se2->setYaw(theta >= kPi ? theta - kTwoPi : theta);
  compound->as<ob::RealVectorStateSpace::StateType>(1)->values[0] = pose.z;
}

double DubinsAirplaneSpace::distance(const ob::State* from, const ob::State* to) const {
  const ModelParams& p = model_->params();
  return DubinsAirplanePath(ToPose(from), ToPose(to), p.GroundTurnRadius(), p.GroundClimbAngle()).Length();
}

void DubinsAirplaneSpace::interpolate(const ob::State* from, const ob::State* to, double t,
                                      ob::State* state) const {
  const ModelParams& p = model_->params();
  const DubinsAirplanePath path(ToPose(from), ToPose(to), p.GroundTurnRadius(), p.GroundClimbAngle());
  FromPose(path.PoseAt(t * path.Length()), state);
}

ob::StateSamplerPtr DubinsAirplaneSpace::allocDefaultStateSampler() const {
  return std::make_shared<AltitudeBandSampler>(this);
}

AltitudeBandSampler::AltitudeBandSampler(const DubinsAirplaneSpace* space)
    : ob::StateSampler(space), model_(space->model()) {}

bool AltitudeBandSampler::SampleAltitude(double x, double y, double* z) {
  const RiskMap& map = model_.map();
  int i = 0;
  int j = 0;
  if (!map.CellOf(x, y, &i, &j) || map.nofly(i, j)) return false;
  const double low = model_.SafeAltitude(i, j);
  const double high = map.terrain(i, j) + model_.params().max_agl_m;
  if (!(low <= high)) return false;
  *z = low + rng_.uniform01() * (high - low);
  return true;
}

void AltitudeBandSampler::sampleUniform(ob::State* state) {
  const RiskMap& map = model_.map();
  // More than 99 % of demo-city is flyable: a redraw is rare.
  for (int attempt = 0; attempt < 1000; ++attempt) {
    const double x = map.x0() + rng_.uniform01() * map.width_m();
    const double y = map.y0() + rng_.uniform01() * map.height_m();
    const double theta = rng_.uniform01() * kTwoPi;
    double z = 0.0;
    if (!SampleAltitude(x, y, &z)) continue;
    DubinsAirplaneSpace::FromPose(Pose{x, y, z, theta}, state);
    return;
  }
  // Nothing flyable found: the state keeps its value and fails validity.
}

void AltitudeBandSampler::sampleUniformNear(ob::State* state, const ob::State* near,
                                            double distance) {
  const Pose c = DubinsAirplaneSpace::ToPose(near);
  for (int attempt = 0; attempt < 100; ++attempt) {
    const double x = c.x + rng_.uniformReal(-distance, distance);
    const double y = c.y + rng_.uniformReal(-distance, distance);
    double z = 0.0;
    if (!SampleAltitude(x, y, &z)) continue;
    DubinsAirplaneSpace::FromPose(Pose{x, y, z, rng_.uniform01() * kTwoPi}, state);
    return;
  }
  space_->copyState(state, near);
}

void AltitudeBandSampler::sampleGaussian(ob::State* state, const ob::State* mean, double std_dev) {
  const Pose c = DubinsAirplaneSpace::ToPose(mean);
  const RiskMap& map = model_.map();
  for (int attempt = 0; attempt < 100; ++attempt) {
    const double x = c.x + rng_.gaussian(0.0, std_dev);
    const double y = c.y + rng_.gaussian(0.0, std_dev);
    int i = 0;
    int j = 0;
    if (!map.CellOf(x, y, &i, &j) || map.nofly(i, j)) continue;
    const double low = model_.SafeAltitude(i, j);
    const double high = map.terrain(i, j) + model_.params().max_agl_m;
    if (!(low <= high)) continue;
    const double z = std::clamp(c.z + rng_.gaussian(0.0, std_dev), low, high);
    const double theta = c.theta + rng_.gaussian(0.0, std_dev / model_.params().GroundTurnRadius());
    DubinsAirplaneSpace::FromPose(Pose{x, y, z, theta}, state);
    return;
  }
  space_->copyState(state, mean);
}

}  // namespace riskplan::bench
