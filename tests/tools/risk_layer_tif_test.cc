// riskplan-tool risk-layer's GeoTIFF, end to end: the real binary on a
// geo-referenced bundle, the file read back with GDAL and compared with the
// library's layer value for value.
#include <gdal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "core/map/demo_city.h"
#include "core/map/map_bundle.h"
#include "core/risk/risk_layer.h"
#include "core/risk/risk_model.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace riskplan {
namespace {

using ::testing::HasSubstr;

std::string RunTool(const std::string& args, int* exit_code) {
  const std::string command = std::string(RISKPLAN_BIN_DIR) + "/riskplan-tool " + args + " 2>&1";
  std::string text;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return text;
  char buffer[4096];
  size_t n = 0;
  while ((n = fread(buffer, 1, sizeof buffer, pipe)) > 0) text.append(buffer, n);
  const int status = pclose(pipe);
  *exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return text;
}

struct Closer {
  void operator()(GDALDatasetH d) const { GDALClose(d); }
};

TEST(RiskLayerTifTest, TheGeoTiffHoldsTheLibrarysLayer) {
  const std::string dir = ::testing::TempDir() + "/risk_layer_tif_test." + std::to_string(getpid());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  // A 1 km demo-city at 10 m cells, placed at Luxembourg.
  auto demo = MakeDemoCity(DemoCityOptions{.size_m = 1000.0, .res_m = 10.0});
  ASSERT_TRUE(demo.ok()) << demo.status();
  MapHeader header = (*demo)->header();
  header.name = "lux-demo";
  header.geo = GeoReference{49.6, 6.1, "test"};
  auto map = RiskMap::Create(header, (*demo)->layers());
  ASSERT_TRUE(map.ok()) << map.status();
  ASSERT_TRUE(WriteMapBundle(**map, dir + "/lux").ok());

  int code = -1;
  const std::string out = RunTool("risk-layer --map=" + dir + "/lux --out=" + dir +
                                      "/layer --agl_m=60 --heading_deg=max --stride=2",
                                  &code);
  ASSERT_EQ(code, 0) << out;
  EXPECT_THAT(out, HasSubstr("wrote " + dir + "/layer.tif (Cloud-Optimized GeoTIFF"));

  auto model = RiskModel::Create(*map, ModelParams{});
  ASSERT_TRUE(model.ok());
  auto layer =
      ComputeRiskLayer(**model, {.height_agl_m = 60.0, .heading_rad = std::nan(""), .stride = 2});
  ASSERT_TRUE(layer.ok()) << layer.status();

  GDALAllRegister();
  std::unique_ptr<void, Closer> ds(GDALOpen((dir + "/layer.tif").c_str(), GA_ReadOnly));
  ASSERT_NE(ds, nullptr);
  EXPECT_STREQ(GDALGetMetadataItem(ds.get(), "LAYOUT", "IMAGE_STRUCTURE"), "COG");
  EXPECT_NE(std::string(GDALGetProjectionRef(ds.get())).find("Azimuthal"), std::string::npos)
      << GDALGetProjectionRef(ds.get());
  ASSERT_EQ(GDALGetRasterXSize(ds.get()), layer->nx);
  ASSERT_EQ(GDALGetRasterYSize(ds.get()), layer->ny);
  std::vector<double> values(static_cast<size_t>(layer->nx) * layer->ny);
  ASSERT_EQ(GDALRasterIO(GDALGetRasterBand(ds.get(), 1), GF_Read, 0, 0, layer->nx, layer->ny,
                         values.data(), layer->nx, layer->ny, GDT_Float64, 0, 0),
            CE_None);
  int nodata = 0;
  for (int row = 0; row < layer->ny; ++row) {
    for (int c = 0; c < layer->nx; ++c) {
      const double expected = layer->at(c, layer->ny - 1 - row);
      const double got = values[static_cast<size_t>(row) * layer->nx + c];
      if (std::isnan(expected)) {
        EXPECT_TRUE(std::isnan(got));
        ++nodata;
      } else {
        EXPECT_EQ(got, expected);
      }
    }
  }
  EXPECT_GT(nodata, 0);  // the band along the edges where the impact leaves the map
  EXPECT_LT(nodata, layer->nx * layer->ny);
  ds.reset();
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace riskplan
