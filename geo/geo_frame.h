// The map's local frame on the Earth: WGS84 latitude and longitude <-> local
// metres, through PROJ.
#ifndef RISKPLAN_GEO_GEO_FRAME_H_
#define RISKPLAN_GEO_GEO_FRAME_H_

#include <memory>
#include <span>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/map/risk_map.h"

namespace riskplan::geo {

// A WGS84 position in degrees (latitude first, as people and ground stations
// write it; PROJ's and GIS's x/y order is longitude first).
struct LatLon {
  double lat_deg = 0.0;
  double lon_deg = 0.0;
};

// A point in a map's local frame, metres east and north.
struct LocalXY {
  double x = 0.0;
  double y = 0.0;
};

// A pose on the Earth, the WGS84 form of a local Pose: position in degrees,
// altitude above mean sea level (exactly the local z: both frames measure
// altitude the same way) and the geographic heading, the azimuth of the
// direction of flight in degrees clockwise from true north.
struct GeoPose {
  double lat_deg = 0.0;
  double lon_deg = 0.0;
  double alt_m = 0.0;        // m AMSL
  double heading_deg = 0.0;  // clockwise from true north; [0, 360) when converted
};

// The WGS84 extent of a local rectangle: its corners (south-west, south-east,
// north-east, north-west) and the smallest latitude/longitude box holding its
// edges (a straight local edge is neither a parallel nor a meridian: the south
// edge of a map whose origin is its south-west corner leaves the origin due
// east along a geodesic and runs south of the origin's parallel, by about
// 1.5 m at 8 km at latitude 50).
struct GeoBounds {
  LatLon corners[4];
  double min_lat_deg = 0.0;
  double max_lat_deg = 0.0;
  double min_lon_deg = 0.0;
  double max_lon_deg = 0.0;
};

// The local frame of a geo-referenced map (docs/map-bundle.md): the azimuthal
// equidistant projection on the WGS84 ellipsoid centred at the geo-reference
// origin, with false easting x0 and false northing y0, so the origin is the
// map point (x0, y0). It is the frame riskplan-tool's .prj and GeoTIFF files
// declare and the one the importer warps every input into; the ENU tangent
// plane at the same point differs from it by s^3/(6 R^2) at distance s (2.1 mm
// at 8 km), see docs/geodata.md.
//
// Thread-safe: every call may come from any thread (each holds its own PROJ
// context and operation, created per call batch).
class GeoFrame {
 public:
  // InvalidArgument for a latitude outside [-90, 90], a longitude outside
  // [-180, 180] or a non-finite value; Internal if PROJ refuses the definition.
  static absl::StatusOr<GeoFrame> Create(const GeoReference& geo, double x0_m, double y0_m);

  double origin_lat_deg() const { return lat0_; }
  double origin_lon_deg() const { return lon0_; }
  double x0() const { return x0_; }
  double y0() const { return y0_; }

  // The PROJ definition of the local frame as a CRS, for PROJ and GDAL
  // ("+proj=aeqd +lat_0=... +type=crs").
  const std::string& proj_definition() const { return proj_; }

  // Converts points; every input must be finite, latitudes in [-90, 90],
  // longitudes in [-180, 180]; InvalidArgument names the first bad point by
  // index. Local points farther than 1000 km from the origin are refused (the
  // frame is meant for a city; PROJ's series are not).
  absl::StatusOr<std::vector<LocalXY>> ToLocal(const std::vector<LatLon>& points) const;
  absl::StatusOr<std::vector<LatLon>> ToWgs84(const std::vector<LocalXY>& points) const;

  absl::StatusOr<LocalXY> ToLocal(const LatLon& p) const;
  absl::StatusOr<LatLon> ToWgs84(const LocalXY& p) const;

  // Whether ToWgs84 takes the local point: finite and at most 1000 km from
  // the origin (a caller converting many points, some perhaps absurd, picks
  // out those it can convert in one batch).
  bool Covers(double x, double y) const;

  // Poses, with their headings. A geographic heading psi at a point becomes
  // the local theta of the same direction of flight: the direction, in the
  // local frame, of the image of a 1 m step either side of the point at
  // azimuth psi (central differences, exact to about 1e-12 rad; the step is
  // taken on the ellipsoid's meridian and prime-vertical radii). Up to the
  // azimuthal equidistant projection's angular distortion (below 1e-6 rad
  // within 20 km of the origin) that is
  //   theta = pi/2 - psi + gamma,
  // gamma the grid convergence at the point (GridConvergenceRad). ToWgs84
  // does the reverse, so a heading survives the round trip to 1e-9 degrees.
  // Headings may be any finite value; results are normalised (theta into
  // [0, 2 pi), heading_deg into [0, 360)). Errors as for points, also for a
  // non-finite altitude or heading, naming the pose by index; and a heading at
  // a pole (within 1e-6 of cos(lat) = 0), where azimuths are undefined.
  absl::StatusOr<std::vector<Pose>> ToLocal(std::span<const GeoPose> poses) const;
  absl::StatusOr<std::vector<GeoPose>> ToWgs84(std::span<const Pose> poses) const;

  // The grid convergence at local point `p`: the angle, in radians, from true
  // north to the local frame's +y axis (grid north), positive clockwise, as
  // PROJ computes it (proj_factors, meridian_convergence). Zero on the
  // origin's meridian; about (lon - lon0) sin(lat0) near the origin (positive
  // east of the origin in the northern hemisphere, where the meridians
  // converge towards the pole).
  absl::StatusOr<double> GridConvergenceRad(const LocalXY& p) const;

  // The WGS84 extent of the local rectangle [x_min, x_max] x [y_min, y_max]
  // (each edge sampled at 65 points for the box). REQUIRES: x_min <= x_max,
  // y_min <= y_max.
  absl::StatusOr<GeoBounds> BoundsOf(double x_min, double y_min, double x_max, double y_max) const;

 private:
  GeoFrame(double lat0, double lon0, double x0, double y0, std::string proj)
      : lat0_(lat0), lon0_(lon0), x0_(x0), y0_(y0), proj_(std::move(proj)) {}

  double lat0_, lon0_, x0_, y0_;
  std::string proj_;
};

// The frame of a map header, or FailedPrecondition when the map has no
// geo-reference (demo-city has none).
absl::StatusOr<GeoFrame> FrameOfMap(const MapHeader& header);

}  // namespace riskplan::geo

#endif  // RISKPLAN_GEO_GEO_FRAME_H_
