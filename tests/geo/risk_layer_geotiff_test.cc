// The risk layer's Cloud-Optimized GeoTIFF, read back with GDAL: layout,
// north-up rows, geotransform, NODATA for undefined cells, and a CRS that
// puts the layer's corner where the map's geo-reference says.
#include "geo/risk_layer_geotiff.h"

#include <gdal.h>
#include <ogr_srs_api.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace riskplan::geo {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// 5 x 4 cells of 10 m at (1000, -500); value 100 * row + column, NaN along
// the west column.
RiskLayer TestLayer() {
  RiskLayer layer;
  layer.nx = 5;
  layer.ny = 4;
  layer.x0 = 1000.0;
  layer.y0 = -500.0;
  layer.res_m = 10.0;
  for (int r = 0; r < layer.ny; ++r) {
    for (int c = 0; c < layer.nx; ++c) layer.risk.push_back(c == 0 ? kNaN : 1e-6 * (100 * r + c));
  }
  return layer;
}

std::string TempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          ("riskplan_tif_" + std::to_string(getpid()) + "_" + name))
      .string();
}

struct Closer {
  void operator()(GDALDatasetH d) const { GDALClose(d); }
};

TEST(RiskLayerGeoTiffTest, IsACogWithNorthUpRowsNodataAndTheMapsFrame) {
  auto frame = GeoFrame::Create({49.6, 6.1, "test"}, 1000.0, -500.0);
  ASSERT_TRUE(frame.ok());
  const RiskLayer layer = TestLayer();
  const std::string path = TempPath("layer.tif");
  ASSERT_TRUE(
      WriteRiskLayerGeoTiff(layer, &*frame, {"lux-test", 100.0, "max over heading bins"}, path)
          .ok());
  GDALAllRegister();
  std::unique_ptr<void, Closer> ds(GDALOpen(path.c_str(), GA_ReadOnly));
  ASSERT_NE(ds, nullptr);
  EXPECT_STREQ(GDALGetDriverShortName(GDALGetDatasetDriver(ds.get())), "GTiff");
  // The COG driver marks its files so (GDAL >= 3.1).
  const char* layout = GDALGetMetadataItem(ds.get(), "LAYOUT", "IMAGE_STRUCTURE");
  ASSERT_NE(layout, nullptr);
  EXPECT_STREQ(layout, "COG");
  EXPECT_STREQ(GDALGetMetadataItem(ds.get(), "COMPRESSION", "IMAGE_STRUCTURE"), "DEFLATE");
  EXPECT_STREQ(GDALGetMetadataItem(ds.get(), "RISKPLAN_MAP", nullptr), "lux-test");
  EXPECT_EQ(GDALGetRasterXSize(ds.get()), 5);
  EXPECT_EQ(GDALGetRasterYSize(ds.get()), 4);
  double gt[6];
  ASSERT_EQ(GDALGetGeoTransform(ds.get(), gt), CE_None);
  EXPECT_EQ(gt[0], 1000.0);
  EXPECT_EQ(gt[1], 10.0);
  EXPECT_EQ(gt[2], 0.0);
  EXPECT_EQ(gt[3], -500.0 + 40.0);  // the north edge
  EXPECT_EQ(gt[4], 0.0);
  EXPECT_EQ(gt[5], -10.0);
  GDALRasterBandH band = GDALGetRasterBand(ds.get(), 1);
  EXPECT_EQ(GDALGetRasterDataType(band), GDT_Float64);
  int has_nodata = 0;
  const double nodata = GDALGetRasterNoDataValue(band, &has_nodata);
  EXPECT_TRUE(has_nodata);
  EXPECT_TRUE(std::isnan(nodata));
  std::vector<double> values(20);
  ASSERT_EQ(GDALRasterIO(band, GF_Read, 0, 0, 5, 4, values.data(), 5, 4, GDT_Float64, 0, 0),
            CE_None);
  for (int row = 0; row < 4; ++row) {
    for (int c = 0; c < 5; ++c) {
      const double expected = layer.at(c, 3 - row);  // file row 0 is the layer's north row
      const double got = values[row * 5 + c];
      if (std::isnan(expected)) {
        EXPECT_TRUE(std::isnan(got)) << row << ", " << c;
      } else {
        EXPECT_EQ(got, expected) << row << ", " << c;
      }
    }
  }
  // The file's CRS takes the layer's south-west corner (the map's
  // geo-reference origin) to (49.6, 6.1), and a cell centre where the
  // frame puts it.
  OGRSpatialReferenceH srs = OSRNewSpatialReference(GDALGetProjectionRef(ds.get()));
  ASSERT_NE(srs, nullptr);
  OGRSpatialReferenceH wgs84 = OSRNewSpatialReference(nullptr);
  OSRImportFromEPSG(wgs84, 4326);
  OSRSetAxisMappingStrategy(wgs84, OAMS_TRADITIONAL_GIS_ORDER);
  OSRSetAxisMappingStrategy(srs, OAMS_TRADITIONAL_GIS_ORDER);
  OGRCoordinateTransformationH ct = OCTNewCoordinateTransformation(srs, wgs84);
  ASSERT_NE(ct, nullptr);
  double x[2] = {1000.0, 1000.0 + 45.0}, y[2] = {-500.0, -500.0 + 35.0}, z[2] = {0, 0};
  ASSERT_TRUE(OCTTransform(ct, 2, x, y, z));
  EXPECT_NEAR(x[0], 6.1, 1e-10);
  EXPECT_NEAR(y[0], 49.6, 1e-10);
  auto centre = frame->ToWgs84(LocalXY{1045.0, -465.0});
  ASSERT_TRUE(centre.ok());
  EXPECT_NEAR(x[1], centre->lon_deg, 1e-10);
  EXPECT_NEAR(y[1], centre->lat_deg, 1e-10);
  OCTDestroyCoordinateTransformation(ct);
  OSRDestroySpatialReference(wgs84);
  OSRDestroySpatialReference(srs);
  ds.reset();
  std::filesystem::remove(path);
}

TEST(RiskLayerGeoTiffTest, WithoutAGeoReferenceTheFileHasNoCrs) {
  const std::string path = TempPath("local.tif");
  ASSERT_TRUE(WriteRiskLayerGeoTiff(TestLayer(), nullptr, {"demo-city", 50.0, "0 deg"}, path).ok());
  GDALAllRegister();
  std::unique_ptr<void, Closer> ds(GDALOpen(path.c_str(), GA_ReadOnly));
  ASSERT_NE(ds, nullptr);
  EXPECT_STREQ(GDALGetProjectionRef(ds.get()), "");
  double gt[6];
  ASSERT_EQ(GDALGetGeoTransform(ds.get(), gt), CE_None);
  EXPECT_EQ(gt[0], 1000.0);
  ds.reset();
  std::filesystem::remove(path);
}

TEST(RiskLayerGeoTiffTest, RefusesAnEmptyLayerAndAnUnwritablePath) {
  RiskLayer empty;
  EXPECT_EQ(WriteRiskLayerGeoTiff(empty, nullptr, {}, TempPath("empty.tif")).code(),
            absl::StatusCode::kInvalidArgument);
  const absl::Status s =
      WriteRiskLayerGeoTiff(TestLayer(), nullptr, {}, "/nonexistent-dir/layer.tif");
  EXPECT_FALSE(s.ok());
  EXPECT_THAT(s.message(), ::testing::HasSubstr("/nonexistent-dir/layer.tif"));
}

}  // namespace
}  // namespace riskplan::geo
