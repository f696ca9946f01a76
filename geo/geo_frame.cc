#include "geo/geo_frame.h"

#include <proj.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_format.h"

namespace riskplan::geo {
namespace {

// Beyond this distance from the origin the local frame is not a city's.
constexpr double kMaxLocalRadiusM = 1.0e6;

struct ContextDeleter {
  void operator()(PJ_CONTEXT* c) const { proj_context_destroy(c); }
};
struct PjDeleter {
  void operator()(PJ* p) const { proj_destroy(p); }
};

// One PROJ context and the bare projection (radians in, metres out): PROJ
// objects are not thread-safe, so each batch of conversions makes its own.
class Projection {
 public:
  static absl::StatusOr<Projection> Make(const std::string& definition) {
    std::unique_ptr<PJ_CONTEXT, ContextDeleter> ctx(proj_context_create());
    if (ctx == nullptr) return absl::InternalError("PROJ: cannot create a context");
    // Never look for grids on the network or write a cache.
    proj_context_set_enable_network(ctx.get(), 0);
    proj_log_level(ctx.get(), PJ_LOG_NONE);
    std::unique_ptr<PJ, PjDeleter> pj(proj_create(ctx.get(), definition.c_str()));
    if (pj == nullptr) {
      return absl::InternalError(
          absl::StrFormat("PROJ refuses '%s': %s", definition,
                          proj_context_errno_string(ctx.get(), proj_context_errno(ctx.get()))));
    }
    return Projection(std::move(ctx), std::move(pj));
  }
  PJ* pj() const { return pj_.get(); }

 private:
  Projection(std::unique_ptr<PJ_CONTEXT, ContextDeleter> ctx, std::unique_ptr<PJ, PjDeleter> pj)
      : ctx_(std::move(ctx)), pj_(std::move(pj)) {}
  // Declared first so it is destroyed last.
  std::unique_ptr<PJ_CONTEXT, ContextDeleter> ctx_;
  std::unique_ptr<PJ, PjDeleter> pj_;
};

// The bare projection, without "+type=crs": proj_trans then maps radians.
std::string OperationOf(double lat0, double lon0, double x0, double y0) {
  return absl::StrFormat("+proj=aeqd +lat_0=%.17g +lon_0=%.17g +x_0=%.17g +y_0=%.17g +ellps=WGS84",
                         lat0, lon0, x0, y0);
}

bool ValidLatLon(double lat, double lon) {
  return lat >= -90.0 && lat <= 90.0 && lon >= -180.0 && lon <= 180.0;
}

// WGS84, for the radii of curvature of a heading's step.
constexpr double kSemiMajorM = 6378137.0;
constexpr double kFlattening = 1.0 / 298.257223563;
constexpr double kE2 = kFlattening * (2.0 - kFlattening);
constexpr double kDegPerRad = 180.0 / kPi;
// Half the step along a heading: 1 m either side of the point.
constexpr double kHeadingStepM = 1.0;
// Below this cos(lat) a point is at a pole, where azimuths are undefined.
constexpr double kMinCosLat = 1e-6;

double MeridianRadius(double phi) {
  const double s = std::sin(phi);
  return kSemiMajorM * (1.0 - kE2) / std::pow(1.0 - kE2 * s * s, 1.5);
}

double PrimeVerticalRadius(double phi) {
  const double s = std::sin(phi);
  return kSemiMajorM / std::sqrt(1.0 - kE2 * s * s);
}

double NormalizeDegrees(double deg) {
  double d = std::fmod(deg, 360.0);
  if (d < 0.0) d += 360.0;
  if (d >= 360.0) d = 0.0;
  return d;
}

// Local (x, y) of (lat, lon) in radians; not finite when PROJ fails.
LocalXY Forward(PJ* pj, double phi, double lam) {
  const PJ_COORD r = proj_trans(pj, PJ_FWD, proj_coord(lam, phi, 0.0, 0.0));
  return {r.xy.x, r.xy.y};
}

struct LatLonRad {
  double phi = 0.0;
  double lam = 0.0;
};

// (lat, lon) in radians of local (x, y); not finite when PROJ fails.
LatLonRad InverseRad(PJ* pj, double x, double y) {
  const PJ_COORD r = proj_trans(pj, PJ_INV, proj_coord(x, y, 0.0, 0.0));
  return {r.lp.phi, r.lp.lam};
}

}  // namespace

absl::StatusOr<GeoFrame> GeoFrame::Create(const GeoReference& geo, double x0_m, double y0_m) {
  const double lat = geo.origin_lat_deg;
  const double lon = geo.origin_lon_deg;
  if (!ValidLatLon(lat, lon) || !std::isfinite(x0_m) || !std::isfinite(y0_m)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "geo-reference: origin (%.9g, %.9g) deg at local (%.9g, %.9g) m: the latitude must be in "
        "[-90, 90], the longitude in [-180, 180], the local origin finite",
        lat, lon, x0_m, y0_m));
  }
  std::string crs = absl::StrFormat(
      "+proj=aeqd +lat_0=%.17g +lon_0=%.17g +x_0=%.17g +y_0=%.17g +datum=WGS84 +units=m +no_defs "
      "+type=crs",
      lat, lon, x0_m, y0_m);
  // Checked once here, so later conversions fail only on their points.
  if (auto p = Projection::Make(OperationOf(lat, lon, x0_m, y0_m)); !p.ok()) return p.status();
  return GeoFrame(lat, lon, x0_m, y0_m, std::move(crs));
}

absl::StatusOr<std::vector<LocalXY>> GeoFrame::ToLocal(const std::vector<LatLon>& points) const {
  for (size_t k = 0; k < points.size(); ++k) {
    if (!ValidLatLon(points[k].lat_deg, points[k].lon_deg)) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "point %d: (%.9g, %.9g) is not a WGS84 latitude in [-90, 90] and longitude in "
          "[-180, 180]",
          k, points[k].lat_deg, points[k].lon_deg));
    }
  }
  auto proj = Projection::Make(OperationOf(lat0_, lon0_, x0_, y0_));
  if (!proj.ok()) return proj.status();
  std::vector<LocalXY> out(points.size());
  for (size_t k = 0; k < points.size(); ++k) {
    const PJ_COORD in =
        proj_coord(proj_torad(points[k].lon_deg), proj_torad(points[k].lat_deg), 0.0, 0.0);
    const PJ_COORD r = proj_trans(proj->pj(), PJ_FWD, in);
    const double dx = r.xy.x - x0_, dy = r.xy.y - y0_;
    if (!std::isfinite(r.xy.x) || !std::isfinite(r.xy.y) ||
        std::hypot(dx, dy) > kMaxLocalRadiusM) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "point %d: (%.9g, %.9g) deg is more than %.0f km from the map's geo-reference origin "
          "(%.9g, %.9g)",
          k, points[k].lat_deg, points[k].lon_deg, kMaxLocalRadiusM / 1000.0, lat0_, lon0_));
    }
    out[k] = {r.xy.x, r.xy.y};
  }
  return out;
}

absl::StatusOr<std::vector<LatLon>> GeoFrame::ToWgs84(const std::vector<LocalXY>& points) const {
  for (size_t k = 0; k < points.size(); ++k) {
    const double dx = points[k].x - x0_, dy = points[k].y - y0_;
    if (!std::isfinite(points[k].x) || !std::isfinite(points[k].y) ||
        std::hypot(dx, dy) > kMaxLocalRadiusM) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "point %d: local (%.9g, %.9g) m is not finite or more than %.0f km from the map's "
          "origin (%.9g, %.9g) m",
          k, points[k].x, points[k].y, kMaxLocalRadiusM / 1000.0, x0_, y0_));
    }
  }
  auto proj = Projection::Make(OperationOf(lat0_, lon0_, x0_, y0_));
  if (!proj.ok()) return proj.status();
  std::vector<LatLon> out(points.size());
  for (size_t k = 0; k < points.size(); ++k) {
    const PJ_COORD r =
        proj_trans(proj->pj(), PJ_INV, proj_coord(points[k].x, points[k].y, 0.0, 0.0));
    if (!std::isfinite(r.lp.lam) || !std::isfinite(r.lp.phi)) {
      return absl::InternalError(
          absl::StrFormat("point %d: PROJ cannot invert local (%.9g, %.9g) m", k, points[k].x,
                          points[k].y));
    }
    out[k] = {proj_todeg(r.lp.phi), proj_todeg(r.lp.lam)};
  }
  return out;
}

bool GeoFrame::Covers(double x, double y) const {
  return std::isfinite(x) && std::isfinite(y) && std::hypot(x - x0_, y - y0_) <= kMaxLocalRadiusM;
}

absl::StatusOr<LocalXY> GeoFrame::ToLocal(const LatLon& p) const {
  auto v = ToLocal(std::vector<LatLon>{p});
  if (!v.ok()) return v.status();
  return (*v)[0];
}

absl::StatusOr<LatLon> GeoFrame::ToWgs84(const LocalXY& p) const {
  auto v = ToWgs84(std::vector<LocalXY>{p});
  if (!v.ok()) return v.status();
  return (*v)[0];
}

absl::StatusOr<std::vector<Pose>> GeoFrame::ToLocal(std::span<const GeoPose> poses) const {
  for (size_t k = 0; k < poses.size(); ++k) {
    const GeoPose& p = poses[k];
    if (!ValidLatLon(p.lat_deg, p.lon_deg) || !std::isfinite(p.alt_m) ||
        !std::isfinite(p.heading_deg)) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "pose %d: (%.9g, %.9g) deg, altitude %.9g m, heading %.9g deg: the latitude must be in "
          "[-90, 90], the longitude in [-180, 180], the altitude and heading finite",
          k, p.lat_deg, p.lon_deg, p.alt_m, p.heading_deg));
    }
    if (std::cos(proj_torad(p.lat_deg)) < kMinCosLat) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "pose %d: latitude %.9g deg is at a pole, where a heading has no meaning", k, p.lat_deg));
    }
  }
  auto proj = Projection::Make(OperationOf(lat0_, lon0_, x0_, y0_));
  if (!proj.ok()) return proj.status();
  std::vector<Pose> out(poses.size());
  for (size_t k = 0; k < poses.size(); ++k) {
    const GeoPose& p = poses[k];
    const double phi = proj_torad(p.lat_deg), lam = proj_torad(p.lon_deg);
    const double psi = proj_torad(p.heading_deg);
    // A step of kHeadingStepM at azimuth psi, in radians of latitude and
    // longitude; its two ends' images give the local direction.
    const double dphi = kHeadingStepM * std::cos(psi) / MeridianRadius(phi);
    const double dlam = kHeadingStepM * std::sin(psi) / (PrimeVerticalRadius(phi) * std::cos(phi));
    const LocalXY c = Forward(proj->pj(), phi, lam);
    const LocalXY ahead = Forward(proj->pj(), phi + dphi, lam + dlam);
    const LocalXY behind = Forward(proj->pj(), phi - dphi, lam - dlam);
    const double dx = c.x - x0_, dy = c.y - y0_;
    if (!std::isfinite(c.x) || !std::isfinite(c.y) || !std::isfinite(ahead.x) ||
        !std::isfinite(behind.x) || std::hypot(dx, dy) > kMaxLocalRadiusM) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "pose %d: (%.9g, %.9g) deg is more than %.0f km from the map's geo-reference origin "
          "(%.9g, %.9g)",
          k, p.lat_deg, p.lon_deg, kMaxLocalRadiusM / 1000.0, lat0_, lon0_));
    }
    out[k] = Pose{c.x, c.y, p.alt_m,
                  NormalizeHeading(std::atan2(ahead.y - behind.y, ahead.x - behind.x))};
  }
  return out;
}

absl::StatusOr<std::vector<GeoPose>> GeoFrame::ToWgs84(std::span<const Pose> poses) const {
  for (size_t k = 0; k < poses.size(); ++k) {
    const Pose& p = poses[k];
    const double dx = p.x - x0_, dy = p.y - y0_;
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) ||
        !std::isfinite(p.theta) || std::hypot(dx, dy) > kMaxLocalRadiusM) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "pose %d: local (%.9g, %.9g, %.9g, %.9g) is not finite or more than %.0f km from the "
          "map's origin (%.9g, %.9g) m",
          k, p.x, p.y, p.z, p.theta, kMaxLocalRadiusM / 1000.0, x0_, y0_));
    }
  }
  auto proj = Projection::Make(OperationOf(lat0_, lon0_, x0_, y0_));
  if (!proj.ok()) return proj.status();
  std::vector<GeoPose> out(poses.size());
  for (size_t k = 0; k < poses.size(); ++k) {
    const Pose& p = poses[k];
    const double ux = kHeadingStepM * std::cos(p.theta), uy = kHeadingStepM * std::sin(p.theta);
    const LatLonRad c = InverseRad(proj->pj(), p.x, p.y);
    const LatLonRad ahead = InverseRad(proj->pj(), p.x + ux, p.y + uy);
    const LatLonRad behind = InverseRad(proj->pj(), p.x - ux, p.y - uy);
    if (!std::isfinite(c.phi) || !std::isfinite(c.lam) || !std::isfinite(ahead.phi) ||
        !std::isfinite(behind.phi)) {
      return absl::InternalError(
          absl::StrFormat("pose %d: PROJ cannot invert local (%.9g, %.9g) m", k, p.x, p.y));
    }
    if (std::cos(c.phi) < kMinCosLat) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "pose %d: local (%.9g, %.9g) m is at a pole, where a heading has no meaning", k, p.x,
          p.y));
    }
    // The step's north and east components on the ellipsoid (the longitude
    // difference wrapped, should the step cross the antimeridian).
    const double north = (ahead.phi - behind.phi) * MeridianRadius(c.phi);
    const double dlam = std::remainder(ahead.lam - behind.lam, 2.0 * kPi);
    const double east = dlam * PrimeVerticalRadius(c.phi) * std::cos(c.phi);
    out[k] = GeoPose{proj_todeg(c.phi), proj_todeg(c.lam), p.z,
                     NormalizeDegrees(std::atan2(east, north) * kDegPerRad)};
  }
  return out;
}

absl::StatusOr<double> GeoFrame::GridConvergenceRad(const LocalXY& p) const {
  auto ll = ToWgs84(p);
  if (!ll.ok()) return ll.status();
  auto proj = Projection::Make(OperationOf(lat0_, lon0_, x0_, y0_));
  if (!proj.ok()) return proj.status();
  const PJ_FACTORS f = proj_factors(
      proj->pj(), proj_coord(proj_torad(ll->lon_deg), proj_torad(ll->lat_deg), 0.0, 0.0));
  if (!std::isfinite(f.meridian_convergence)) {
    return absl::InternalError(absl::StrFormat(
        "PROJ cannot compute the grid convergence at local (%.9g, %.9g) m", p.x, p.y));
  }
  return f.meridian_convergence;
}

absl::StatusOr<GeoBounds> GeoFrame::BoundsOf(double x_min, double y_min, double x_max,
                                             double y_max) const {
  constexpr int kPerEdge = 65;
  // Corners first (south-west, south-east, north-east, north-west), then
  // the inner points of each edge.
  std::vector<LocalXY> points = {{x_min, y_min}, {x_max, y_min}, {x_max, y_max}, {x_min, y_max}};
  for (int k = 1; k < kPerEdge - 1; ++k) {
    const double t = static_cast<double>(k) / (kPerEdge - 1);
    const double x = x_min + t * (x_max - x_min), y = y_min + t * (y_max - y_min);
    points.push_back({x, y_min});
    points.push_back({x, y_max});
    points.push_back({x_min, y});
    points.push_back({x_max, y});
  }
  auto ll = ToWgs84(points);
  if (!ll.ok()) return ll.status();
  GeoBounds b;
  for (int k = 0; k < 4; ++k) b.corners[k] = (*ll)[k];
  b.min_lat_deg = b.max_lat_deg = (*ll)[0].lat_deg;
  b.min_lon_deg = b.max_lon_deg = (*ll)[0].lon_deg;
  for (const LatLon& p : *ll) {
    b.min_lat_deg = std::min(b.min_lat_deg, p.lat_deg);
    b.max_lat_deg = std::max(b.max_lat_deg, p.lat_deg);
    b.min_lon_deg = std::min(b.min_lon_deg, p.lon_deg);
    b.max_lon_deg = std::max(b.max_lon_deg, p.lon_deg);
  }
  return b;
}

absl::StatusOr<GeoFrame> FrameOfMap(const MapHeader& header) {
  if (!header.geo.has_value()) {
    return absl::FailedPreconditionError(absl::StrFormat(
        "map '%s' has no geo-reference, so it has no WGS84 coordinates", header.name));
  }
  return GeoFrame::Create(*header.geo, header.x0, header.y0);
}

}  // namespace riskplan::geo
