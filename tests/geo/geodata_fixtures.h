// Synthetic geodata that GDAL itself writes, for the importer's tests, and
// the real data of Debian's r-cran-terra and r-cran-satellite packages.
#ifndef RISKPLAN_TESTS_GEO_GEODATA_FIXTURES_H_
#define RISKPLAN_TESTS_GEO_GEODATA_FIXTURES_H_

#include <gdal.h>

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/map/risk_map.h"
#include "geo/geo_frame.h"
#include "geo/map_importer.h"

namespace riskplan::geo::testing {

// A new empty directory for one test (under the test temp dir).
std::string FreshDir(const std::string& name);

// A raster to write: `values` north row first (as GDAL stores them), one
// band.
struct RasterSpec {
  std::string srs = "EPSG:4326";
  double geotransform[6] = {0, 1, 0, 0, 0, -1};
  int width = 0;
  int height = 0;
  GDALDataType type = GDT_Float32;
  std::vector<double> values;
  bool has_nodata = false;
  double nodata = 0.0;
  std::string area_or_point;  // "" (GDAL's default, Area), "Area" or "Point"
  std::vector<uint8_t> mask;  // a per-dataset mask band (0 masked), empty for none
  std::string driver = "GTiff";
  // Write the geotransform as given even for a pixel-is-point raster (what a
  // GeoTIFF whose tie point is the first pixel's centre holds).
  bool raw_point_tiepoint = false;
};
absl::Status WriteRaster(const std::string& path, const RasterSpec& spec);

// A feature to write: geometry as WKT in the layer's CRS (GIS order: x is
// longitude or easting), and attributes.
struct FeatureSpec {
  std::string wkt;
  std::map<std::string, double> numbers = {};
  std::map<std::string, std::string> texts = {};
};
absl::Status WriteVector(const std::string& path, const std::string& driver, const std::string& srs,
                         const std::string& layer, const std::vector<FeatureSpec>& features);

// (x, y) in `from` carried into `to`, both in GIS order.
absl::StatusOr<std::pair<double, double>> Carry(const std::string& from, const std::string& to,
                                                double x, double y);

// The cell (i, j) of a WGS84 point in an imported map, or (-1, -1) outside.
std::pair<int, int> CellOfLatLon(const ImportedMap& map, double lat, double lon);

// The value of a layer at cell (i, j) (south row first).
inline float At(const std::vector<float>& layer, const MapHeader& h, int i, int j) {
  return layer[static_cast<size_t>(j) * h.nx + i];
}

// The directory of R's site-library that holds terra/ex/ and
// satellite/extdata/, from scripts/fetch-geodata.sh (apt-get download and
// dpkg-deb -x into the build tree). The caller ASSERTs the status: without
// the data the tests fail, they never skip.
absl::StatusOr<std::string> RealGeodataDir();

}  // namespace riskplan::geo::testing

#endif  // RISKPLAN_TESTS_GEO_GEODATA_FIXTURES_H_
