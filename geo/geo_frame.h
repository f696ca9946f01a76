// The map's local frame on the Earth: WGS84 latitude and longitude <-> local
// metres, through PROJ.
#ifndef RISKPLAN_GEO_GEO_FRAME_H_
#define RISKPLAN_GEO_GEO_FRAME_H_

#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
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
