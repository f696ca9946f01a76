#include "server/flight/emergency_landing.h"

#include <cmath>
#include <limits>
#include <numbers>

#include "core/base/wind.h"
#include "core/map/risk_map.h"

namespace riskplan::server {

absl::StatusOr<std::shared_ptr<const std::vector<double>>> GlideLayerOf(
    const RiskModel& model, const StopCondition& /*stop*/) {
  return model.glide_layer();
}

absl::StatusOr<std::shared_ptr<const std::vector<double>>> GlideLayerRepaired(
    const RiskModel& model, const std::vector<uint8_t>& nofly, const StopCondition& stop) {
  const RiskMap& map = model.map();
  const ModelParams& p = model.params();
  const WindVector w = WindVectorOf(p.wind_speed_mps, p.wind_from_deg);
  std::vector<double> glide = *model.glide_layer();
  if (absl::Status s = RepairGlideAltitude(
          map.nx(), map.ny(), map.res(), map.layers().terrain, map.landing_sites(), p.glide_ratio,
          p.glide_clearance_m, GlideWind{w.x, w.y, p.GlideAirspeed()}, map.nofly_layer(), nofly,
          &glide, stop);
      !s.ok()) {
    return s;
  }
  return std::make_shared<const std::vector<double>>(std::move(glide));
}

absl::StatusOr<std::shared_ptr<const std::vector<double>>> GlideLayerWith(
    const RiskMap& map, const std::vector<uint8_t>& nofly, const ModelParams& p,
    const StopCondition& stop) {
  const WindVector w = WindVectorOf(p.wind_speed_mps, p.wind_from_deg);
  absl::StatusOr<std::vector<double>> glide = ComputeGlideAltitude(
      map.nx(), map.ny(), map.res(), map.layers().terrain, nofly, map.landing_sites(),
      p.glide_ratio, p.glide_clearance_m, stop, GlideWind{w.x, w.y, p.GlideAirspeed()});
  if (!glide.ok()) return glide.status();
  return std::make_shared<const std::vector<double>>(*std::move(glide));
}

std::optional<EmergencyOption> FindEmergencyLanding(const RiskMap& map, const ModelParams& p,
                                                    const std::vector<double>& glide,
                                                    const Pose& from) {
  int ci = 0, cj = 0;
  if (!map.CellOf(from.x, from.y, &ci, &cj)) return std::nullopt;
  const double start_glide = glide[map.Index(ci, cj)];
  if (!std::isfinite(start_glide) || !(from.z >= start_glide)) return std::nullopt;

  // dist / G(c -> n) for a glide from c to n = c + (di, dj), as
  // ComputeGlideAltitude computes it (the same expressions).
  const double res = map.res();
  const WindVector w = WindVectorOf(p.wind_speed_mps, p.wind_from_deg);
  const bool calm = w.x == 0.0 && w.y == 0.0;
  constexpr int kDi[8] = {1, -1, 0, 0, 1, 1, -1, -1};
  constexpr int kDj[8] = {0, 0, 1, -1, 1, -1, 1, -1};
  double climb[8];
  for (int d = 0; d < 8; ++d) {
    const double dist = d < 4 ? res : res * std::numbers::sqrt2;
    if (calm) {
      climb[d] = dist / p.glide_ratio;
      continue;
    }
    const double norm = d < 4 ? 1.0 : std::numbers::sqrt2;
    const double dx = kDi[d] / norm;
    const double dy = kDj[d] / norm;
    const double along = w.x * dx + w.y * dy;
    const double across = -w.x * dy + w.y * dx;
    const double vg = p.GlideAirspeed();
    const double ground = std::fabs(across) < vg ? std::sqrt(vg * vg - across * across) + along : 0.0;
    climb[d] = ground > 0.0 ? dist / (p.glide_ratio * ground / vg)
                            : std::numeric_limits<double>::infinity();
  }

  const auto site_at = [&](int i, int j) -> const LandingSite* {
    for (const LandingSite& s : map.landing_sites()) {
      if (s.i == i && s.j == j) return &s;
    }
    return nullptr;
  };
  const auto centre = [&](int i, int j, double z, double theta) {
    return Pose{map.x0() + (i + 0.5) * res, map.y0() + (j + 0.5) * res, z, theta};
  };

  EmergencyOption option;
  option.altitude_margin_m = from.z - start_glide;
  double alt = from.z;
  option.glide.push_back(centre(ci, cj, alt, from.theta));
  // The glide altitude falls strictly at every step, so at most nx * ny steps.
  const int64_t max_steps = static_cast<int64_t>(map.nx()) * map.ny();
  for (int64_t step = 0; step <= max_steps; ++step) {
    const double here = glide[map.Index(ci, cj)];
    const LandingSite* site = site_at(ci, cj);
    if (site != nullptr && here == static_cast<double>(map.terrain(ci, cj)) + p.glide_clearance_m) {
      option.site = site->name;
      option.site_i = ci;
      option.site_j = cj;
      option.site_pose = centre(ci, cj, here, option.glide.back().theta);
      return option;
    }
    int best = -1;
    double best_alt = std::numeric_limits<double>::infinity();
    for (int d = 0; d < 8; ++d) {
      const int ni = ci + kDi[d], nj = cj + kDj[d];
      if (!map.Contains(ni, nj)) continue;
      const double v = glide[map.Index(ni, nj)] + climb[d];
      if (v < best_alt) {
        best_alt = v;
        best = d;
      }
    }
    if (best < 0 || !(best_alt <= here) || !std::isfinite(best_alt)) return std::nullopt;
    ci += kDi[best];
    cj += kDj[best];
    alt -= climb[best];
    option.glide_distance_m += best < 4 ? res : res * std::numbers::sqrt2;
    double heading = std::atan2(kDj[best], kDi[best]);
    if (heading < 0.0) heading += 2.0 * std::numbers::pi;
    option.glide.push_back(centre(ci, cj, alt, heading));
  }
  return std::nullopt;
}

}  // namespace riskplan::server
