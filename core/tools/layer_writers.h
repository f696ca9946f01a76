// File formats for risk layers (riskplan-tool risk-layer).
#ifndef RISKPLAN_CORE_TOOLS_LAYER_WRITERS_H_
#define RISKPLAN_CORE_TOOLS_LAYER_WRITERS_H_

#include <string>

#include "absl/status/status.h"
#include "core/risk_layer.h"

namespace riskplan {

// Writes the layer as an ESRI ASCII grid (.asc, readable by GDAL and QGIS) in
// the map's local frame; NODATA is -9999.
absl::Status WriteAsciiGrid(const RiskLayer& layer, const std::string& path);

// Writes the layer as an 8-bit RGB PNG heat map (north up): log10 of M mapped
// from the 1st to the 99.9th percentile of the positive values onto a
// black-red-yellow-white scale; cells with M = 0 are dark blue.
absl::Status WriteHeatMapPng(const RiskLayer& layer, const std::string& path);

}  // namespace riskplan

#endif  // RISKPLAN_CORE_TOOLS_LAYER_WRITERS_H_
