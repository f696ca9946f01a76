#include "client/mission.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "absl/strings/str_format.h"

namespace riskplan::client {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;
constexpr double kEarthRadiusM = 6371008.8;  // WGS84 mean radius

double Wrap360(double deg) {
  double d = std::fmod(deg, 360.0);
  if (d < 0.0) d += 360.0;
  return d;
}

}  // namespace

std::string MissionItemName(const geo::MissionPoint& point) {
  return absl::StrFormat("mission item %d (%s)", point.item,
                         std::string(geo::MissionPointKindName(point.kind)));
}

double InitialBearingDeg(double lat1_deg, double lon1_deg, double lat2_deg, double lon2_deg) {
  const double p1 = lat1_deg * kDeg;
  const double p2 = lat2_deg * kDeg;
  const double dl = (lon2_deg - lon1_deg) * kDeg;
  const double y = std::sin(dl) * std::cos(p2);
  const double x = std::cos(p1) * std::sin(p2) - std::sin(p1) * std::cos(p2) * std::cos(dl);
  return Wrap360(std::atan2(y, x) / kDeg);
}

double LegDistanceM(const geo::MissionPoint& a, const geo::MissionPoint& b) {
  const double p1 = a.lat_deg * kDeg;
  const double p2 = b.lat_deg * kDeg;
  const double dp = p2 - p1;
  const double dl = (b.lon_deg - a.lon_deg) * kDeg;
  const double h =
      std::sin(dp / 2) * std::sin(dp / 2) + std::cos(p1) * std::cos(p2) * std::sin(dl / 2) * std::sin(dl / 2);
  const double d = 2.0 * kEarthRadiusM * std::asin(std::min(1.0, std::sqrt(h)));
  return std::hypot(d, b.alt_m - a.alt_m);
}

std::vector<double> MissionHeadings(const geo::QgcMission& mission) {
  const std::vector<geo::MissionPoint>& p = mission.points;
  std::vector<double> out(p.size(), 0.0);
  auto bearing = [&](size_t i, size_t j) {
    return InitialBearingDeg(p[i].lat_deg, p[i].lon_deg, p[j].lat_deg, p[j].lon_deg);
  };
  for (size_t k = 0; k < p.size(); ++k) {
    if (p[k].heading_deg.has_value()) {
      out[k] = Wrap360(*p[k].heading_deg);
      continue;
    }
    const bool has_in = k > 0;
    const bool has_out = k + 1 < p.size();
    if (has_in && has_out) {
      const double in = bearing(k - 1, k) * kDeg;
      const double o = bearing(k, k + 1) * kDeg;
      const double x = std::cos(in) + std::cos(o);
      const double y = std::sin(in) + std::sin(o);
      out[k] = std::hypot(x, y) < 1e-9 ? o / kDeg : Wrap360(std::atan2(y, x) / kDeg);
    } else if (has_out) {
      out[k] = bearing(k, k + 1);
    } else if (has_in) {
      out[k] = bearing(k - 1, k);
    }
  }
  return out;
}

std::vector<MissionLeg> MissionLegs(const geo::QgcMission& mission,
                                    const std::vector<double>& headings_deg) {
  std::vector<MissionLeg> legs;
  auto pose = [&](size_t k) {
    v1::GeoPose g;
    g.set_lat_deg(mission.points[k].lat_deg);
    g.set_lon_deg(mission.points[k].lon_deg);
    g.set_alt_m(mission.points[k].alt_m);
    g.set_heading_deg(headings_deg[k]);
    return g;
  };
  for (size_t k = 0; k + 1 < mission.points.size(); ++k) {
    legs.push_back(MissionLeg{.from = k, .to = k + 1, .start = pose(k), .goal = pose(k + 1)});
  }
  return legs;
}

v1::FlightLimits LegLimits(const v1::FlightLimits& whole, const MissionUsed& used,
                           const geo::QgcMission& mission, const std::vector<MissionLeg>& legs,
                           size_t leg) {
  double remaining_distance = 0.0;
  for (size_t k = leg; k < legs.size(); ++k) {
    remaining_distance += LegDistanceM(mission.points[legs[k].from], mission.points[legs[k].to]);
  }
  const double d = LegDistanceM(mission.points[legs[leg].from], mission.points[legs[leg].to]);
  // The last leg takes all that remains; the others their share by distance.
  const double share =
      leg + 1 == legs.size() || remaining_distance <= 0.0 ? 1.0 : d / remaining_distance;
  auto split = [&](double limit, double spent) {
    if (limit <= 0.0) return 0.0;  // no limit
    const double left = limit - spent;
    // Used up: the smallest positive limit, which no trajectory meets, so
    // the leg ends with the limit's own note.
    return left <= 0.0 ? std::numeric_limits<double>::min() : left * share;
  };
  v1::FlightLimits out;
  out.set_max_flight_time_s(split(whole.max_flight_time_s(), used.flight_time_s));
  out.set_max_length_m(split(whole.max_length_m(), used.length_m));
  out.set_max_risk(split(whole.max_risk(), used.risk));
  out.set_max_risk_per_flight_hour(whole.max_risk_per_flight_hour());
  out.set_objective(whole.objective());
  return out;
}

absl::StatusOr<JoinedRoute> JoinLegs(const std::vector<geo::ExportTrajectory>& legs) {
  if (legs.empty()) return absl::InvalidArgumentError("a mission route needs at least one leg");
  JoinedRoute out;
  out.route = legs.front();
  out.route.samples.clear();
  double arc = 0.0;
  for (size_t i = 0; i < legs.size(); ++i) {
    const std::vector<geo::ExportSample>& s = legs[i].samples;
    if (s.size() < 2) {
      return absl::InvalidArgumentError(
          absl::StrFormat("leg %d has %d samples; a leg needs at least 2", i + 1, s.size()));
    }
    for (size_t k = i == 0 ? 0 : 1; k < s.size(); ++k) {
      geo::ExportSample sample = s[k];
      sample.arc_length_m = arc + s[k].arc_length_m;
      out.route.samples.push_back(sample);
    }
    arc += s.back().arc_length_m;
    out.leg_end_sample.push_back(out.route.samples.size() - 1);
  }
  return out;
}

}  // namespace riskplan::client
