#include "server/flight/flight_zones.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace riskplan::server {
namespace {

double Cross(ZoneVertex2 o, ZoneVertex2 a, ZoneVertex2 b) {
  return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
}

bool OnSegment(ZoneVertex2 a, ZoneVertex2 b, ZoneVertex2 p) {
  return std::min(a.x, b.x) <= p.x && p.x <= std::max(a.x, b.x) && std::min(a.y, b.y) <= p.y &&
         p.y <= std::max(a.y, b.y);
}

int Sign(double v) { return v > 0.0 ? 1 : (v < 0.0 ? -1 : 0); }

double SegmentDistance(ZoneVertex2 a, ZoneVertex2 b, double x, double y) {
  const double dx = b.x - a.x;
  const double dy = b.y - a.y;
  const double len2 = dx * dx + dy * dy;
  double t = len2 > 0.0 ? ((x - a.x) * dx + (y - a.y) * dy) / len2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  return std::hypot(a.x + t * dx - x, a.y + t * dy - y);
}

absl::Status Finite(double v, std::string_view field) {
  if (!std::isfinite(v)) {
    return absl::InvalidArgumentError(absl::StrFormat("%s has value %g; it must be finite", field, v));
  }
  return absl::OkStatus();
}

}  // namespace

bool SegmentsIntersect(ZoneVertex2 a, ZoneVertex2 b, ZoneVertex2 c, ZoneVertex2 d) {
  const int d1 = Sign(Cross(c, d, a));
  const int d2 = Sign(Cross(c, d, b));
  const int d3 = Sign(Cross(a, b, c));
  const int d4 = Sign(Cross(a, b, d));
  if (d1 * d2 < 0 && d3 * d4 < 0) return true;
  if (d1 == 0 && OnSegment(c, d, a)) return true;
  if (d2 == 0 && OnSegment(c, d, b)) return true;
  if (d3 == 0 && OnSegment(a, b, c)) return true;
  if (d4 == 0 && OnSegment(a, b, d)) return true;
  return false;
}

bool FlightZoneSpec::ContainsXY(double x, double y) const {
  if (is_circle) return std::hypot(x - centre.x, y - centre.y) <= radius_m;
  // Even-odd rule, then the boundary itself.
  bool inside = false;
  const size_t n = polygon.size();
  for (size_t i = 0, j = n - 1; i < n; j = i++) {
    const ZoneVertex2 a = polygon[i];
    const ZoneVertex2 b = polygon[j];
    if ((a.y > y) != (b.y > y)) {
      const double xc = a.x + (y - a.y) * (b.x - a.x) / (b.y - a.y);
      if (x < xc) inside = !inside;
    }
  }
  return inside || DistanceXY(x, y) == 0.0;
}

double FlightZoneSpec::DistanceXY(double x, double y) const {
  if (is_circle) return std::max(0.0, std::hypot(x - centre.x, y - centre.y) - radius_m);
  bool inside = false;
  double best = std::numeric_limits<double>::infinity();
  const size_t n = polygon.size();
  for (size_t i = 0, j = n - 1; i < n; j = i++) {
    const ZoneVertex2 a = polygon[i];
    const ZoneVertex2 b = polygon[j];
    if ((a.y > y) != (b.y > y)) {
      const double xc = a.x + (y - a.y) * (b.x - a.x) / (b.y - a.y);
      if (x < xc) inside = !inside;
    }
    best = std::min(best, SegmentDistance(a, b, x, y));
  }
  return inside ? 0.0 : best;
}

bool FlightZoneSpec::Contains(const Pose& pose) const {
  if (!ContainsXY(pose.x, pose.y)) return false;
  if (min_alt_m.has_value() && pose.z < *min_alt_m) return false;
  if (max_alt_m.has_value() && pose.z > *max_alt_m) return false;
  return true;
}

absl::StatusOr<FlightZoneSpec> ZoneFromProto(const v1::FlightZone& zone, const ZoneLimits& limits,
                                             std::string_view field) {
  FlightZoneSpec spec;
  if (zone.id().empty() || zone.id().size() > limits.max_id_chars) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s.id has %d characters; a zone id must have 1 to %d", field,
                        zone.id().size(), limits.max_id_chars));
  }
  spec.id = zone.id();
  switch (zone.shape_case()) {
    case v1::FlightZone::kCircle: {
      const v1::ZoneCircle& c = zone.circle();
      spec.is_circle = true;
      if (absl::Status s = Finite(c.x(), absl::StrCat(std::string(field), ".circle.x")); !s.ok()) return s;
      if (absl::Status s = Finite(c.y(), absl::StrCat(std::string(field), ".circle.y")); !s.ok()) return s;
      if (!(c.radius_m() > 0.0 && c.radius_m() <= limits.max_radius_m)) {
        return absl::InvalidArgumentError(
            absl::StrFormat("%s.circle.radius_m has value %g; it must be in (0, %g]", field,
                            c.radius_m(), limits.max_radius_m));
      }
      spec.centre = {c.x(), c.y()};
      spec.radius_m = c.radius_m();
      break;
    }
    case v1::FlightZone::kPolygon: {
      const auto& vs = zone.polygon().vertices();
      if (vs.size() < 3 || static_cast<size_t>(vs.size()) > limits.max_vertices) {
        return absl::InvalidArgumentError(
            absl::StrFormat("%s.polygon.vertices has %d vertices; a zone polygon has 3 to %d "
                            "(--max_zone_vertices)",
                            field, vs.size(), limits.max_vertices));
      }
      for (int k = 0; k < vs.size(); ++k) {
        if (!std::isfinite(vs[k].x()) || !std::isfinite(vs[k].y())) {
          return absl::InvalidArgumentError(absl::StrFormat(
              "%s.polygon.vertices[%d] is (%g, %g); its coordinates must be finite", field, k,
              vs[k].x(), vs[k].y()));
        }
        spec.polygon.push_back({vs[k].x(), vs[k].y()});
      }
      const size_t n = spec.polygon.size();
      double area2 = 0.0;
      for (size_t i = 0; i < n; ++i) {
        const ZoneVertex2 a = spec.polygon[i];
        const ZoneVertex2 b = spec.polygon[(i + 1) % n];
        area2 += a.x * b.y - b.x * a.y;
      }
      // Edges that are not neighbours must not touch; neighbours meet only
      // at their shared vertex (no fold back along each other).
      for (size_t i = 0; i < n; ++i) {
        for (size_t j = i + 1; j < n; ++j) {
          const bool adjacent = j == i + 1 || (i == 0 && j == n - 1);
          const ZoneVertex2 a = spec.polygon[i], b = spec.polygon[(i + 1) % n];
          const ZoneVertex2 c = spec.polygon[j], d = spec.polygon[(j + 1) % n];
          if (adjacent) {
            // The shared vertex is b == c (j == i + 1) or a == d (wrap):
            // they fold back when the far ends lie on the shared line
            // and on the same side.
            const ZoneVertex2 shared = j == i + 1 ? b : a;
            const ZoneVertex2 p = j == i + 1 ? a : b;
            const ZoneVertex2 q = j == i + 1 ? d : c;
            if (Cross(shared, p, q) == 0.0 &&
                (p.x - shared.x) * (q.x - shared.x) + (p.y - shared.y) * (q.y - shared.y) > 0.0) {
              return absl::InvalidArgumentError(absl::StrFormat(
                  "%s.polygon.vertices: edges %d and %d fold back on each other (the polygon "
                  "intersects itself)",
                  field, i, j));
            }
            continue;
          }
          if (SegmentsIntersect(a, b, c, d)) {
            return absl::InvalidArgumentError(absl::StrFormat(
                "%s.polygon.vertices: edges %d and %d cross (the polygon intersects itself)",
                field, i, j));
          }
        }
      }
      if (!(std::fabs(area2) > 0.0)) {
        return absl::InvalidArgumentError(
            absl::StrFormat("%s.polygon.vertices enclose no area", field));
      }
      break;
    }
    default:
      return absl::InvalidArgumentError(
          absl::StrFormat("%s has no shape; set polygon or circle", field));
  }
  if (zone.has_min_alt_m() != zone.has_max_alt_m()) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s: an altitude band needs both min_alt_m and max_alt_m (only %s is set)", field,
        zone.has_min_alt_m() ? "min_alt_m" : "max_alt_m"));
  }
  if (zone.has_min_alt_m()) {
    if (!std::isfinite(zone.min_alt_m()) || !std::isfinite(zone.max_alt_m()) ||
        !(zone.min_alt_m() < zone.max_alt_m())) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "%s band is [%g, %g] m; min_alt_m and max_alt_m must be finite with min < max", field,
          zone.min_alt_m(), zone.max_alt_m()));
    }
    spec.min_alt_m = zone.min_alt_m();
    spec.max_alt_m = zone.max_alt_m();
  }
  if (!std::isfinite(zone.valid_from_s()) || zone.valid_from_s() < 0.0) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s.valid_from_s has value %g; it must be finite and >= 0", field, zone.valid_from_s()));
  }
  if (!std::isfinite(zone.valid_until_s()) ||
      (zone.valid_until_s() != 0.0 && !(zone.valid_until_s() > zone.valid_from_s()))) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s.valid_until_s has value %g; it must be 0 (for ever) or after valid_from_s (%g)",
        field, zone.valid_until_s(), zone.valid_from_s()));
  }
  spec.valid_from_s = zone.valid_from_s();
  spec.valid_until_s = zone.valid_until_s();
  return spec;
}

int64_t CloseZoneCells(const RiskMap& map, const FlightZoneSpec& zone,
                       std::vector<uint8_t>* nofly) {
  const double res = map.res();
  const double reach = 0.5 * res * std::numbers::sqrt2;
  double x_min, x_max, y_min, y_max;
  if (zone.is_circle) {
    x_min = zone.centre.x - zone.radius_m;
    x_max = zone.centre.x + zone.radius_m;
    y_min = zone.centre.y - zone.radius_m;
    y_max = zone.centre.y + zone.radius_m;
  } else {
    x_min = x_max = zone.polygon[0].x;
    y_min = y_max = zone.polygon[0].y;
    for (const ZoneVertex2& v : zone.polygon) {
      x_min = std::min(x_min, v.x);
      x_max = std::max(x_max, v.x);
      y_min = std::min(y_min, v.y);
      y_max = std::max(y_max, v.y);
    }
  }
  // Cells whose centre may lie within `reach` of the bounding box, clipped to the map.
  const auto clip = [](double v, int n) {
    return static_cast<int>(std::clamp(v, -1.0, static_cast<double>(n)));
  };
  const int i0 = std::max(0, clip(std::floor((x_min - reach - map.x0()) / res), map.nx()));
  const int i1 = std::min(map.nx() - 1, clip(std::floor((x_max + reach - map.x0()) / res), map.nx()));
  const int j0 = std::max(0, clip(std::floor((y_min - reach - map.y0()) / res), map.ny()));
  const int j1 = std::min(map.ny() - 1, clip(std::floor((y_max + reach - map.y0()) / res), map.ny()));
  int64_t closed = 0;
  for (int j = j0; j <= j1; ++j) {
    const double y = map.y0() + (j + 0.5) * res;
    for (int i = i0; i <= i1; ++i) {
      const double x = map.x0() + (i + 0.5) * res;
      uint8_t& cell = (*nofly)[map.Index(i, j)];
      if (cell != 0) continue;
      if (zone.DistanceXY(x, y) <= reach) {
        cell = 1;
        ++closed;
      }
    }
  }
  return closed;
}

std::vector<uint8_t> NoFlyWithZones(const RiskMap& map,
                                    const std::vector<const FlightZoneSpec*>& zones,
                                    int64_t* closed) {
  std::vector<uint8_t> nofly = map.nofly_layer();
  int64_t n = 0;
  for (const FlightZoneSpec* zone : zones) n += CloseZoneCells(map, *zone, &nofly);
  if (closed != nullptr) *closed = n;
  return nofly;
}

absl::StatusOr<std::shared_ptr<const RiskMap>> MapWithZones(
    const std::shared_ptr<const RiskMap>& map, const std::vector<const FlightZoneSpec*>& zones) {
  if (zones.empty()) return map;
  int64_t closed = 0;
  std::vector<uint8_t> nofly = NoFlyWithZones(*map, zones, &closed);
  if (closed == 0) return map;
  return RiskMap::WithNoFly(map, std::move(nofly));
}

}  // namespace riskplan::server
