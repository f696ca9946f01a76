#include "server/api/risk_layer_request.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <tuple>
#include <vector>

#include "absl/strings/str_format.h"
#include "server/api/wgs84_fields.h"
#include "server/api/wind_fields.h"

namespace riskplan::server {
namespace {

// The map cells [i0, i1) x [j0, j1) that the local rectangle overlaps,
// clipped to the map; INVALID_ARGUMENT naming `field` when it overlaps none.
absl::Status WindowOfRect(const RiskMap& map, double x_min, double y_min, double x_max,
                          double y_max, const std::string& field, RiskLayerOptions* options) {
  // Indices computed in double and clipped before any conversion, so a far
  // rectangle cannot overflow an int.
  const double i0 = std::max(0.0, std::floor((x_min - map.x0()) / map.res()));
  const double j0 = std::max(0.0, std::floor((y_min - map.y0()) / map.res()));
  const double i1 = std::min<double>(map.nx(), std::ceil((x_max - map.x0()) / map.res()));
  const double j1 = std::min<double>(map.ny(), std::ceil((y_max - map.y0()) / map.res()));
  if (!(i1 > i0) || !(j1 > j0)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s x in [%g, %g], y in [%g, %g] does not overlap map '%s', which covers x in [%g, %g), "
        "y in [%g, %g)",
        field, x_min, x_max, y_min, y_max, map.name(), map.x0(), map.x0() + map.width_m(), map.y0(),
        map.y0() + map.height_m()));
  }
  options->first_column = static_cast<int>(i0);
  options->first_row = static_cast<int>(j0);
  options->columns = static_cast<int>(i1 - i0);
  options->rows = static_cast<int>(j1 - j0);
  return absl::OkStatus();
}

// The window of a `region` in the map's local metres.
absl::Status WindowOfLocalRegion(const RiskMap& m, const v1::LocalRect& r,
                                 RiskLayerOptions* options) {
  for (auto [name, value] : {std::pair{"x_min_m", r.x_min_m()},
                             {"y_min_m", r.y_min_m()},
                             {"x_max_m", r.x_max_m()},
                             {"y_max_m", r.y_max_m()}}) {
    if (absl::Status s = CheckFinite(value, absl::StrFormat("region.%s", name)); !s.ok()) {
      return s;
    }
  }
  if (!(r.x_min_m() < r.x_max_m()) || !(r.y_min_m() < r.y_max_m())) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "region is x in [%g, %g], y in [%g, %g]; it needs x_min_m < x_max_m and y_min_m < "
        "y_max_m",
        r.x_min_m(), r.x_max_m(), r.y_min_m(), r.y_max_m()));
  }
  return WindowOfRect(m, r.x_min_m(), r.y_min_m(), r.x_max_m(), r.y_max_m(), "region", options);
}

// The window of a `region_wgs84` box: its edges, 65 points each, into the
// local frame; their local bounding box is the region (a box of latitudes and
// longitudes is no rectangle in the local frame, and its edges bulge).
absl::Status WindowOfWgs84Region(const MapRegistry& registry, const RiskMap& m,
                                 const v1::GeoRect& r, RiskLayerOptions* options) {
  absl::StatusOr<std::shared_ptr<const geo::GeoFrame>> frame =
      FrameForField(registry, m, "region_wgs84", "region");
  if (!frame.ok()) return frame.status();
  for (auto [name, value, limit] : {std::tuple{"south_lat_deg", r.south_lat_deg(), 90.0},
                                    {"north_lat_deg", r.north_lat_deg(), 90.0},
                                    {"west_lon_deg", r.west_lon_deg(), 180.0},
                                    {"east_lon_deg", r.east_lon_deg(), 180.0}}) {
    if (!(value >= -limit && value <= limit)) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "region_wgs84.%s has value %g; it must be in [%g, %g]", name, value, -limit, limit));
    }
  }
  if (!(r.south_lat_deg() < r.north_lat_deg()) || !(r.west_lon_deg() < r.east_lon_deg())) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "region_wgs84 is latitudes [%g, %g], longitudes [%g, %g]; it needs south < north "
        "and west < east",
        r.south_lat_deg(), r.north_lat_deg(), r.west_lon_deg(), r.east_lon_deg()));
  }
  constexpr int kPerEdge = 65;
  std::vector<geo::LatLon> edge;
  for (int k = 0; k < kPerEdge; ++k) {
    const double t = static_cast<double>(k) / (kPerEdge - 1);
    const double lat = r.south_lat_deg() + t * (r.north_lat_deg() - r.south_lat_deg());
    const double lon = r.west_lon_deg() + t * (r.east_lon_deg() - r.west_lon_deg());
    edge.push_back({r.south_lat_deg(), lon});
    edge.push_back({r.north_lat_deg(), lon});
    edge.push_back({lat, r.west_lon_deg()});
    edge.push_back({lat, r.east_lon_deg()});
  }
  absl::StatusOr<std::vector<geo::LocalXY>> local = PointsFromWgs84(**frame, edge, "region_wgs84");
  if (!local.ok()) return local.status();
  double x_min = (*local)[0].x, x_max = x_min, y_min = (*local)[0].y, y_max = y_min;
  for (const geo::LocalXY& p : *local) {
    x_min = std::min(x_min, p.x);
    x_max = std::max(x_max, p.x);
    y_min = std::min(y_min, p.y);
    y_max = std::max(y_max, p.y);
  }
  return WindowOfRect(m, x_min, y_min, x_max, y_max, "region_wgs84", options);
}

// The stride, the height above ground and the heading (or the worst heading).
absl::Status SamplingOptions(const v1::GetRiskLayerRequest& request, RiskLayerOptions* options) {
  const int stride = request.stride() == 0 ? 1 : request.stride();
  if (stride < 1 || stride > 4096) {
    return absl::InvalidArgumentError(
        absl::StrFormat("stride has value %d; it must be in [1, 4096] (0: 1)", request.stride()));
  }
  options->stride = stride;
  const double height = request.height_agl_m() == 0.0 ? 100.0 : request.height_agl_m();
  if (!(std::isfinite(height) && height > 0.0 && height <= 10000.0)) {
    return absl::InvalidArgumentError(
        absl::StrFormat("height_agl_m has value %g; it must be finite and in (0, 10000] (0: 100)",
                        request.height_agl_m()));
  }
  options->height_agl_m = height;
  if (absl::Status s = CheckFinite(request.heading_rad(), "heading_rad"); !s.ok()) return s;
  options->heading_rad =
      request.max_over_headings() ? std::nan("") : NormalizeHeading(request.heading_rad());
  return absl::OkStatus();
}

// The layer's cells and configuration risks, against the limits, before any
// work is queued.
absl::Status CheckLayerWork(const v1::GetRiskLayerRequest& request, const RequestLimits& limits,
                            RiskLayerSpec* spec) {
  absl::StatusOr<LayerShape> shape = LayerCells(*spec->map, spec->options);
  if (!shape.ok()) return shape.status();
  spec->cells = static_cast<int64_t>(shape->nx) * shape->ny;
  const int64_t per_cell = request.max_over_headings() ? spec->params.heading_bins : 1;
  spec->evaluations = spec->cells * per_cell;
  if (spec->cells > kMaxRiskLayerCells || spec->evaluations > limits.max_risk_layer_evaluations) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "the risk layer of %d x %d cells (stride %d) needs %d configuration risks%s; the limits "
        "are %d cells and %d risks (--max_risk_layer_evaluations): ask for a smaller region or a "
        "larger stride",
        shape->nx, shape->ny, spec->options.stride, spec->evaluations,
        request.max_over_headings()
            ? absl::StrFormat(" (%d heading bins each)", spec->params.heading_bins)
            : "",
        kMaxRiskLayerCells, limits.max_risk_layer_evaluations));
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<RiskLayerSpec> ValidateRiskLayerRequest(const v1::GetRiskLayerRequest& request,
                                                       const MapRegistry& registry,
                                                       const RequestLimits& limits) {
  RiskLayerSpec spec;
  absl::StatusOr<std::shared_ptr<const RiskMap>> map = FindMap(registry, request.map());
  if (!map.ok()) return map.status();
  spec.map = *std::move(map);
  spec.frame = registry.Frame(spec.map->name());
  spec.options.threads = 1;  // the evaluation pool is the parallelism
  absl::Status area = absl::OkStatus();  // no area: the whole map
  if (request.area_case() == v1::GetRiskLayerRequest::kRegion) {
    area = WindowOfLocalRegion(*spec.map, request.region(), &spec.options);
  } else if (request.area_case() == v1::GetRiskLayerRequest::kRegionWgs84) {
    area = WindowOfWgs84Region(registry, *spec.map, request.region_wgs84(), &spec.options);
  }
  if (!area.ok()) return area;
  if (absl::Status s = SamplingOptions(request, &spec.options); !s.ok()) return s;

  absl::StatusOr<ModelParams> params = ModelParamsFromProto(request.model_params());
  if (!params.ok()) return params.status();
  spec.params = *params;
  if (absl::Status s = ApplyRequestWind(RequestWindOf(request), registry, *spec.map, &spec.params);
      !s.ok()) {
    return s;
  }
  spec.wind = WindReportOf(spec.params, *spec.map, spec.frame.get());
  if (absl::Status s = CheckModelWork(spec.params, limits); !s.ok()) return s;
  if (absl::Status s = CheckLayerWork(request, limits, &spec); !s.ok()) return s;
  return spec;
}

}  // namespace riskplan::server
