#include "geo/target_grid.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_format.h"
#include "core/map/risk_map.h"

namespace riskplan::geo {
namespace {

// The frame is an azimuthal projection about the south-west corner: fine for
// a city anywhere but near a pole, where "east" stops meaning much.
constexpr double kMaxAbsLatDeg = 85.0;
// Points per edge when a bounding box's outline is followed into the frame.
constexpr int kEdgePoints = 64;
// A size within this many cells of a whole number is that number (so 8000 m at
// 5 m is 1600 cells, not 1601 for a rounding error).
constexpr double kWholeCellSlack = 1e-6;
// Corrections of a centred area's corner; each shrinks the centre's error
// about a thousandfold at city scale.
constexpr int kCentreIterations = 3;

absl::StatusOr<int> CellsAlong(const char* what, double extent_m, double res_m) {
  const double cells = std::ceil(extent_m / res_m - kWholeCellSlack);
  if (!(cells >= 1.0 && cells <= kMaxMapSide)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "area: %s of %.9g m at %.9g m cells is %.0f cells; each side must be 1 to %d cells", what,
        extent_m, res_m, cells, kMaxMapSide));
  }
  return static_cast<int>(cells);
}

absl::StatusOr<TargetGrid> GridAt(const LatLon& south_west, double width_m, double height_m,
                                  double res_m) {
  auto nx = CellsAlong("the width", width_m, res_m);
  if (!nx.ok()) return nx.status();
  auto ny = CellsAlong("the height", height_m, res_m);
  if (!ny.ok()) return ny.status();
  const int64_t cells = static_cast<int64_t>(*nx) * *ny;
  if (cells > kMaxMapCells) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "area: %d x %d cells (%d) exceeds the map-bundle limit of %d cells; use larger cells "
        "(--res_m) or a smaller area",
        *nx, *ny, cells, kMaxMapCells));
  }
  GeoReference geo;
  geo.origin_lat_deg = south_west.lat_deg;
  geo.origin_lon_deg = south_west.lon_deg;
  auto frame = GeoFrame::Create(geo, 0.0, 0.0);
  if (!frame.ok()) return frame.status();
  return TargetGrid{*std::move(frame), *nx, *ny, res_m};
}

absl::Status CheckLatitude(const char* what, double lat_deg) {
  if (!(std::abs(lat_deg) <= kMaxAbsLatDeg)) {
    return absl::InvalidArgumentError(
        absl::StrFormat("area: %s latitude %.9g is outside [-%g, %g] deg", what, lat_deg,
                        kMaxAbsLatDeg, kMaxAbsLatDeg));
  }
  return absl::OkStatus();
}

// The outline of a box, kEdgePoints per edge, along meridians and parallels.
std::vector<LatLon> Outline(const LonLatBox& b) {
  std::vector<LatLon> points;
  for (int k = 0; k <= kEdgePoints; ++k) {
    const double t = static_cast<double>(k) / kEdgePoints;
    const double lon = b.west_lon_deg + t * (b.east_lon_deg - b.west_lon_deg);
    const double lat = b.south_lat_deg + t * (b.north_lat_deg - b.south_lat_deg);
    points.push_back({b.south_lat_deg, lon});
    points.push_back({b.north_lat_deg, lon});
    points.push_back({lat, b.west_lon_deg});
    points.push_back({lat, b.east_lon_deg});
  }
  return points;
}

// The centre and the size of a centred area, checked before PROJ runs.
absl::Status CheckCentredArea(const LatLon& c, const AreaSpec& area, double res) {
  if (absl::Status s = CheckLatitude("the centre's", c.lat_deg); !s.ok()) return s;
  if (!(std::isfinite(c.lon_deg) && std::abs(c.lon_deg) <= 180.0)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "area: the centre's longitude %.9g is outside [-180, 180] deg", c.lon_deg));
  }
  for (auto [what, v] : {std::pair{"width", area.width_m}, std::pair{"height", area.height_m}}) {
    if (!(std::isfinite(v) && v > 0.0)) {
      return absl::InvalidArgumentError(
          absl::StrFormat("area: the %s %.9g m must be > 0 and finite", what, v));
    }
  }
  // Fail on the size before PROJ runs on a corner 10^6 km away.
  if (auto nx = CellsAlong("the width", area.width_m, res); !nx.ok()) return nx.status();
  if (auto ny = CellsAlong("the height", area.height_m, res); !ny.ok()) return ny.status();
  return absl::OkStatus();
}

// The south-west corner from which the centre `c` is the middle of a
// width x height area in the corner's own frame.
absl::StatusOr<LatLon> CornerOfCentredArea(const LatLon& c, double width_m, double height_m) {
  auto centred = GeoFrame::Create({c.lat_deg, c.lon_deg, ""}, 0.0, 0.0);
  if (!centred.ok()) return centred.status();
  auto sw = centred->ToWgs84(LocalXY{-width_m / 2, -height_m / 2});
  if (!sw.ok()) {
    return absl::InvalidArgumentError(
        absl::StrFormat("area: the south-west corner: %s", sw.status().message()));
  }
  // The corner's frame is turned from the centre's by the meridians'
  // convergence (3.7 m at 5 km here): move the corner until the centre is
  // the map's middle in the corner's own frame.
  for (int k = 0; k < kCentreIterations; ++k) {
    if (absl::Status s = CheckLatitude("the south-west corner's", sw->lat_deg); !s.ok()) {
      return s;
    }
    auto frame = GeoFrame::Create({sw->lat_deg, sw->lon_deg, ""}, 0.0, 0.0);
    if (!frame.ok()) return frame.status();
    auto at = frame->ToLocal(c);
    if (!at.ok()) return at.status();
    auto moved = frame->ToWgs84(LocalXY{at->x - width_m / 2, at->y - height_m / 2});
    if (!moved.ok()) return moved.status();
    sw = *moved;
  }
  if (absl::Status s = CheckLatitude("the south-west corner's", sw->lat_deg); !s.ok()) return s;
  return *sw;
}

absl::StatusOr<TargetGrid> GridAroundCentre(const LatLon& c, const AreaSpec& area, double res) {
  if (absl::Status s = CheckCentredArea(c, area, res); !s.ok()) return s;
  auto sw = CornerOfCentredArea(c, area.width_m, area.height_m);
  if (!sw.ok()) return sw.status();
  return GridAt(*sw, area.width_m, area.height_m, res);
}

absl::Status CheckBox(const LonLatBox& b) {
  for (auto [what, lat] : {std::pair{"south", b.south_lat_deg}, {"north", b.north_lat_deg}}) {
    if (absl::Status s = CheckLatitude(what, lat); !s.ok()) return s;
  }
  for (auto [what, lon] : {std::pair{"west", b.west_lon_deg}, {"east", b.east_lon_deg}}) {
    if (!(std::isfinite(lon) && std::abs(lon) <= 180.0)) {
      return absl::InvalidArgumentError(
          absl::StrFormat("area: the %s longitude %.9g is outside [-180, 180] deg", what, lon));
    }
  }
  if (!(b.south_lat_deg < b.north_lat_deg)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "area: the bounding box's south %.9g is not below its north %.9g (the order is "
        "WEST,SOUTH,EAST,NORTH)",
        b.south_lat_deg, b.north_lat_deg));
  }
  if (!(b.west_lon_deg < b.east_lon_deg)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "area: the bounding box's west %.9g is not left of its east %.9g (an area across the "
        "antimeridian is not supported; the order is WEST,SOUTH,EAST,NORTH)",
        b.west_lon_deg, b.east_lon_deg));
  }
  return absl::OkStatus();
}

// Fits the box in the frame at its own south-west corner, then moves the
// frame to the fitted rectangle's corner and measures the box again there
// (so that the box is covered to within millimetres).
absl::StatusOr<TargetGrid> GridOverBox(const LonLatBox& b, double res) {
  if (absl::Status s = CheckBox(b); !s.ok()) return s;
  const std::vector<LatLon> outline = Outline(b);
  auto first = GeoFrame::Create({b.south_lat_deg, b.west_lon_deg, ""}, 0.0, 0.0);
  if (!first.ok()) return first.status();
  auto local = first->ToLocal(outline);
  if (!local.ok()) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "area: the bounding box is too large for a local frame: %s", local.status().message()));
  }
  double min_x = 0.0, min_y = 0.0;
  for (const LocalXY& p : *local) {
    min_x = std::min(min_x, p.x);
    min_y = std::min(min_y, p.y);
  }
  auto sw = first->ToWgs84(LocalXY{min_x, min_y});
  if (!sw.ok()) return sw.status();
  auto frame = GeoFrame::Create({sw->lat_deg, sw->lon_deg, ""}, 0.0, 0.0);
  if (!frame.ok()) return frame.status();
  auto moved = frame->ToLocal(outline);
  if (!moved.ok()) return moved.status();
  double max_x = 0.0, max_y = 0.0;
  for (const LocalXY& p : *moved) {
    max_x = std::max(max_x, p.x);
    max_y = std::max(max_y, p.y);
  }
  return GridAt(*sw, max_x, max_y, res);
}

}  // namespace

LatLon TargetGrid::Center() const {
  auto c = frame.ToWgs84(LocalXY{frame.x0() + width_m() / 2, frame.y0() + height_m() / 2});
  return c.ok() ? *c : LatLon{frame.origin_lat_deg(), frame.origin_lon_deg()};
}

absl::StatusOr<TargetGrid> MakeTargetGrid(const AreaSpec& area) {
  const double res = area.res_m;
  if (!(std::isfinite(res) && res > 0.0)) {
    return absl::InvalidArgumentError(
        absl::StrFormat("area: the cell size %.9g m must be > 0 and finite", res));
  }
  if (area.center.has_value() == area.bbox.has_value()) {
    return absl::InvalidArgumentError(
        "area: give either a centre with a size or a bounding box, not both or neither");
  }
  if (area.center.has_value()) return GridAroundCentre(*area.center, area, res);
  return GridOverBox(*area.bbox, res);
}

}  // namespace riskplan::geo
