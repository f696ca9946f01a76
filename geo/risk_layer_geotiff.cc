#include "geo/risk_layer_geotiff.h"

#include <gdal.h>
#include <gdal_priv.h>
#include <ogr_spatialref.h>
#include <unistd.h>

#include <cstdio>
#include <limits>
#include <memory>
#include <mutex>
#include <vector>

#include "absl/strings/str_format.h"

namespace riskplan::geo {
namespace {

struct DatasetCloser {
  void operator()(GDALDataset* d) const { GDALClose(GDALDataset::ToHandle(d)); }
};
using DatasetPtr = std::unique_ptr<GDALDataset, DatasetCloser>;

absl::Status GdalError(const std::string& what) {
  return absl::InternalError(absl::StrFormat("GDAL: %s: %s", what, CPLGetLastErrorMsg()));
}

}  // namespace

absl::Status WriteRiskLayerGeoTiff(const RiskLayer& layer, const GeoFrame* frame,
                                   const RiskLayerDescription& description,
                                   const std::string& path) {
  if (layer.nx < 1 || layer.ny < 1 ||
      layer.risk.size() != static_cast<size_t>(layer.nx) * layer.ny) {
    return absl::InvalidArgumentError(
        absl::StrFormat("GeoTIFF '%s': the layer of %d x %d cells holds %d values", path, layer.nx,
                        layer.ny, layer.risk.size()));
  }
  static std::once_flag registered;
  std::call_once(registered, [] { GDALAllRegister(); });
  GDALDriver* mem = GetGDALDriverManager()->GetDriverByName("MEM");
  GDALDriver* cog = GetGDALDriverManager()->GetDriverByName("COG");
  if (mem == nullptr || cog == nullptr) {
    return absl::InternalError("GDAL has no MEM or COG driver (GDAL >= 3.1 is needed)");
  }
  // GDAL's COG driver writes only by CreateCopy (it lays out the tiles and
  // overviews from a complete source), so the layer is built in memory first.
  DatasetPtr data(mem->Create("", layer.nx, layer.ny, 1, GDT_Float64, nullptr));
  if (data == nullptr) return GdalError("cannot create the in-memory raster");
  // North up: GeoTIFF rows run from the north, the layer's from the south.
  double transform[6] = {layer.x0, layer.res_m, 0.0, layer.y0 + layer.ny * layer.res_m,
                         0.0,      -layer.res_m};
  data->SetGeoTransform(transform);
  if (frame != nullptr) {
    OGRSpatialReference srs;
    if (srs.SetFromUserInput(frame->proj_definition().c_str()) != OGRERR_NONE) {
      return GdalError(absl::StrFormat("cannot read the CRS '%s'", frame->proj_definition()));
    }
    srs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    data->SetSpatialRef(&srs);
  }
  GDALRasterBand* band = data->GetRasterBand(1);
  band->SetNoDataValue(std::numeric_limits<double>::quiet_NaN());
  band->SetDescription("configuration risk M, expected casualties given a failure");
  std::vector<double> row(layer.nx);
  for (int r = 0; r < layer.ny; ++r) {
    const int source = layer.ny - 1 - r;
    for (int c = 0; c < layer.nx; ++c) row[c] = layer.at(c, source);
    if (band->RasterIO(GF_Write, 0, r, layer.nx, 1, row.data(), layer.nx, 1, GDT_Float64, 0, 0,
                       nullptr) != CE_None) {
      return GdalError("cannot fill the in-memory raster");
    }
  }
  data->SetMetadataItem("RISKPLAN_MAP", description.map.c_str());
  data->SetMetadataItem("RISKPLAN_HEIGHT_AGL_M",
                        absl::StrFormat("%.17g", description.height_agl_m).c_str());
  data->SetMetadataItem("RISKPLAN_HEADING", description.heading.c_str());

  // PREDICTOR=YES is the floating-point predictor for a Float64 band; the
  // overviews average the defined cells (NaN is the nodata value). Written
  // to a temporary file and renamed, so that a reader never sees a part.
  const char* options[] = {"COMPRESS=DEFLATE", "PREDICTOR=YES", "BLOCKSIZE=512",
                           "RESAMPLING=AVERAGE", nullptr};
  const std::string tmp = absl::StrFormat("%s.tmp-%d.tif", path, getpid());
  DatasetPtr out(cog->CreateCopy(tmp.c_str(), data.get(), FALSE, const_cast<char**>(options),
                                 nullptr, nullptr));
  if (out == nullptr) {
    std::remove(tmp.c_str());
    return GdalError(absl::StrFormat("cannot write the Cloud-Optimized GeoTIFF '%s'", path));
  }
  out.reset();  // closes (and flushes) the file
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    return absl::UnavailableError(absl::StrFormat("cannot write '%s'", path));
  }
  return absl::OkStatus();
}

}  // namespace riskplan::geo
