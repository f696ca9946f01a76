#include "geo/geo_frame.h"

#include <proj.h>

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

absl::StatusOr<GeoFrame> FrameOfMap(const MapHeader& header) {
  if (!header.geo.has_value()) {
    return absl::FailedPreconditionError(absl::StrFormat(
        "map '%s' has no geo-reference, so it has no WGS84 coordinates", header.name));
  }
  return GeoFrame::Create(*header.geo, header.x0, header.y0);
}

}  // namespace riskplan::geo
