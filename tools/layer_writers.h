// File formats for risk layers (riskplan-tool risk-layer).
#ifndef RISKPLAN_TOOLS_LAYER_WRITERS_H_
#define RISKPLAN_TOOLS_LAYER_WRITERS_H_

#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/map/risk_map.h"
#include "core/risk/risk_layer.h"

namespace riskplan {

// Writes the layer as an ESRI ASCII grid (.asc, readable by GDAL and QGIS) in
// the map's local frame: xllcorner/yllcorner = the layer's (x0, y0), cellsize
// = res_m, northernmost row first, values with 9 significant digits, NaN
// (undefined M) written as NODATA_value -9999.
absl::Status WriteAsciiGrid(const RiskLayer& layer, const std::string& path);

// Writes the layer as an 8-bit RGB PNG heat map (north up): log10 of M mapped
// from the 1st to the 99.9th percentile of the positive values onto a
// black-red-yellow-white scale; cells with M = 0 are dark blue (10, 20, 60),
// cells where M is undefined (NaN) mid grey (128, 128, 128), a colour the
// scale never takes.
absl::Status WriteHeatMapPng(const RiskLayer& layer, const std::string& path);

// The ESRI WKT1 (.prj, as GDAL and QGIS read it next to a .asc) of a local
// azimuthal equidistant projection on WGS84 centred at (geo.origin_lat_deg,
// geo.origin_lon_deg) with false easting x0_m and false northing y0_m: the
// coordinates of a map whose local frame is the ENU tangent plane at its
// point (x0, y0) (docs/map-bundle.md) then land on the ground where they are.
//
// Why that approximates the tangent plane: both projections are azimuthal
// about the same point, so they agree on the direction to every point; they
// differ in the distance from the centre only. The tangent plane shows a
// ground point at arc length s at R*sin(s/R), the azimuthal equidistant one
// at s, a difference of s^3/(6 R^2) + O(s^5): 0.3 mm at 4 km, 2.1 mm at 8 km,
// 5.9 mm at 11.3 km (the far corner of an 8 km x 8 km map), with R the
// Earth's radius of curvature (about 6,370 km; the ellipsoid's flattening
// changes these by about 1 %). The centre being the map's south-west corner,
// s is at most the map's diagonal. (ENU also moves a point h above the
// ellipsoid by about h*s/R sideways, 0.4 m for 300 m at 8 km; a 2-D raster of
// ground cells has no such term.)
//
// Errors (InvalidArgument): latitude outside [-90, 90], longitude outside
// [-180, 180], or a non-finite value.
absl::StatusOr<std::string> LocalAzimuthalEquidistantWkt(const GeoReference& geo,
                                                         const std::string& map_name, double x0_m,
                                                         double y0_m);

// Writes `text` to `path`, replacing the file.
absl::Status WriteTextFile(const std::string& text, const std::string& path);

}  // namespace riskplan

#endif  // RISKPLAN_TOOLS_LAYER_WRITERS_H_
