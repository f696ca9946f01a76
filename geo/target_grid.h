// The grid an import fills: where the map lies on the Earth and how it is cut
// into cells, from an area given in WGS84.
#ifndef RISKPLAN_GEO_TARGET_GRID_H_
#define RISKPLAN_GEO_TARGET_GRID_H_

#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "geo/geo_frame.h"

namespace riskplan::geo {

// A WGS84 bounding box, degrees. West < east (an area across the
// antimeridian is not supported), south < north.
struct LonLatBox {
  double west_lon_deg = 0.0;
  double south_lat_deg = 0.0;
  double east_lon_deg = 0.0;
  double north_lat_deg = 0.0;
};

// The area to import: a centre and a size, or a bounding box; and the cell
// side. Exactly one of `center` and `bbox` is set.
struct AreaSpec {
  std::optional<LatLon> center;
  double width_m = 0.0;   // with center: east-west extent
  double height_m = 0.0;  // with center: north-south extent
  std::optional<LonLatBox> bbox;
  double res_m = 5.0;
};

// The grid of an imported map. Its local frame (docs/map-bundle.md) is the
// azimuthal equidistant projection centred at the map's south-west corner,
// which is the local point (0, 0); cells are res_m square, nx east by ny
// north, so the map covers [0, nx*res_m] x [0, ny*res_m] in that frame.
struct TargetGrid {
  GeoFrame frame;
  int nx = 0;
  int ny = 0;
  double res_m = 0.0;

  double width_m() const { return nx * res_m; }
  double height_m() const { return ny * res_m; }
  int64_t cells() const { return static_cast<int64_t>(nx) * ny; }
  // The WGS84 point of the map's centre.
  LatLon Center() const;
};

// The grid of an area:
//  - center + width x height: the south-west corner is the point from which
//    the centre lies at (width/2, height/2) in the corner's own frame (to a
//    micrometre); nx = ceil(width/res), ny = ceil(height/res).
//  - bbox: the smallest rectangle of whole cells, in the frame at the
//    bounding box's south-west corner, that covers the box (its edges
//    followed along meridians and parallels); its south-west corner becomes
//    the origin (in the northern hemisphere it is the box's own south-west
//    corner, the southern edge bulging north). The box is covered to within
//    millimetres: the frame is moved to the rectangle's corner after fitting.
// InvalidArgument names the field at fault: a non-finite or non-positive
// size or cell, latitudes outside [-85, 85] (the frame is meant for a city,
// not a pole), a box crossing the antimeridian or inverted, or a grid over
// the map-bundle limits (each side at most 65536 cells, nx*ny at most 64 Mi
// cells), checked before anything is allocated.
absl::StatusOr<TargetGrid> MakeTargetGrid(const AreaSpec& area);

}  // namespace riskplan::geo

#endif  // RISKPLAN_GEO_TARGET_GRID_H_
