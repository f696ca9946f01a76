// A risk layer as a Cloud-Optimized GeoTIFF (GDAL's COG driver), for GIS
// tools: riskplan-tool risk-layer's PREFIX.tif.
#ifndef RISKPLAN_GEO_RISK_LAYER_GEOTIFF_H_
#define RISKPLAN_GEO_RISK_LAYER_GEOTIFF_H_

#include <string>

#include "absl/status/status.h"
#include "core/risk/risk_layer.h"
#include "geo/geo_frame.h"

namespace riskplan::geo {

// What the file says about how the layer was computed (TIFF metadata items
// RISKPLAN_MAP, RISKPLAN_HEIGHT_AGL_M, RISKPLAN_HEADING).
struct RiskLayerDescription {
  std::string map;
  double height_agl_m = 0.0;
  std::string heading;  // e.g. "0 deg" or "max over heading bins"
};

// Writes `layer` to `path` as a Cloud-Optimized GeoTIFF: one Float64 band of
// M (expected casualties given a failure at the cell's centre), north up
// (the layer's northernmost row first), geotransform (x0, res_m, 0, y0 +
// ny * res_m, 0, -res_m) in the map's local metres, NODATA NaN where M is
// undefined, DEFLATE with the floating-point predictor, 512 x 512 tiles and
// overviews averaged over defined cells. With `frame` the file's CRS is the
// map's local frame (GeoFrame::proj_definition), so GIS tools place it on
// the Earth; without (a map with no geo-reference) it has no CRS. Written to
// a temporary file renamed over `path`. Errors: InvalidArgument for an empty
// layer, Internal when GDAL refuses (with its message).
absl::Status WriteRiskLayerGeoTiff(const RiskLayer& layer, const GeoFrame* frame,
                                   const RiskLayerDescription& description,
                                   const std::string& path);

}  // namespace riskplan::geo

#endif  // RISKPLAN_GEO_RISK_LAYER_GEOTIFF_H_
