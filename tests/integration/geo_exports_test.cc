// WGS84 end to end with the real server and the real client, on a
// geo-referenced bundle (the 2 km demo-city placed at Luxembourg): a plan
// asked for in WGS84, exported to QGroundControl .plan, GeoJSON and KML,
// reads back (the .plan with nlohmann-json, GeoJSON and KML with GDAL/OGR)
// to the server's sampled path, point for point within 1 cm; maps show both
// frames; a map without geo-reference refuses WGS84 naming map and field;
// GetRiskLayer gives riskplan-tool's layer and refuses a layer too large.
#include <gdal.h>
#include <ogr_api.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "client/client.h"
#include "core/map/demo_city.h"
#include "core/map/map_bundle.h"
#include "geo/geo_frame.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/integration/server_process.h"

namespace riskplan::testing {
namespace {

using ::testing::HasSubstr;
using Json = nlohmann::json;

constexpr double kLat0 = 49.6;
constexpr double kLon0 = 6.1;
constexpr double kCentimetre = 0.01;

struct Closer {
  void operator()(GDALDatasetH d) const { GDALClose(d); }
};

class GeoExportsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    char dir[] = "/tmp/riskplan-geo-XXXXXX";
    ASSERT_NE(mkdtemp(dir), nullptr);
    dir_ = new std::string(dir);
    // The 2 km demo-city twice: placed at Luxembourg ("lux-demo"), and
    // without a geo-reference ("plain").
    auto demo = MakeDemoCity(DemoCityOptions{.size_m = kSmallCitySizeM});
    ASSERT_TRUE(demo.ok()) << demo.status();
    for (bool geo : {true, false}) {
      MapHeader header = (*demo)->header();
      header.name = geo ? "lux-demo" : "plain";
      if (geo) header.geo = GeoReference{kLat0, kLon0, "test placement"};
      auto map = RiskMap::Create(header, (*demo)->layers());
      ASSERT_TRUE(map.ok()) << map.status();
      ASSERT_TRUE(WriteMapBundle(**map, *dir_ + "/maps/" + header.name).ok());
    }
    auto server =
        ServerProcess::Start({"--maps=" + *dir_ + "/maps", "--max_risk_layer_evaluations=1000000"});
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = server->release();
    auto frame = geo::GeoFrame::Create({kLat0, kLon0, ""}, 0.0, 0.0);
    ASSERT_TRUE(frame.ok());
    frame_ = new geo::GeoFrame(*frame);
  }
  static void TearDownTestSuite() {
    delete server_;
    server_ = nullptr;
    RunCommand("rm -rf " + *dir_);
    delete dir_;
    delete frame_;
  }
  void SetUp() override {
    ASSERT_NE(server_, nullptr);
    client_ = std::make_unique<client::RiskplanClient>(server_->Channel());
  }

  static CommandResult Cli(const std::string& args) {
    return RunCommand(std::string(RISKPLAN_BIN_DIR) + "/riskplan " + server_->CliServerFlags() +
                      " " + args + " 2>&1");
  }
  static std::string Read(const std::string& path) {
    std::ifstream in(path);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
  }

  // "wgs84:lat,lon,alt,heading" of a local pose.
  static std::string Wgs84Text(const Pose& p) {
    auto g = frame_->ToWgs84(std::vector<Pose>{p});
    EXPECT_TRUE(g.ok()) << g.status();
    return absl::StrFormat("wgs84:%.12f,%.12f,%.3f,%.9f", (*g)[0].lat_deg, (*g)[0].lon_deg,
                           (*g)[0].alt_m, (*g)[0].heading_deg);
  }

  // The local position of a WGS84 one, to compare in metres.
  static geo::LocalXY Local(double lat, double lon) {
    auto xy = frame_->ToLocal(geo::LatLon{lat, lon});
    EXPECT_TRUE(xy.ok()) << xy.status();
    return xy.ok() ? *xy : geo::LocalXY{NAN, NAN};
  }

  static void ExpectWithinACentimetre(double lat, double lon, double alt, const v1::Pose& expected,
                                      const std::string& where) {
    const geo::LocalXY xy = Local(lat, lon);
    EXPECT_NEAR(xy.x, expected.x(), kCentimetre) << where;
    EXPECT_NEAR(xy.y, expected.y(), kCentimetre) << where;
    EXPECT_NEAR(alt, expected.z(), kCentimetre) << where;
  }

  static ServerProcess* server_;
  static std::string* dir_;
  static geo::GeoFrame* frame_;
  std::unique_ptr<client::RiskplanClient> client_;
};
ServerProcess* GeoExportsTest::server_ = nullptr;
std::string* GeoExportsTest::dir_ = nullptr;
geo::GeoFrame* GeoExportsTest::frame_ = nullptr;

TEST_F(GeoExportsTest, APlanInWgs84ExportedReadsBackToTheSamePointsWithinACentimetre) {
  const Pose start{300, 375, 240, 0.785}, goal{1700, 1625, 250, 0.785};
  const std::string plan = *dir_ + "/mission.plan", geojson = *dir_ + "/mission.geojson",
                    kml = *dir_ + "/mission.kml", traj = *dir_ + "/mission.json";
  CommandResult r =
      Cli("plan --map=lux-demo --start=" + Wgs84Text(start) + " --goal=" + Wgs84Text(goal) +
          " --budget_ms=0 --iterations=1500 --seed=7 --export_spacing_m=40"
          " --plan_out=" +
          plan + " --geojson_out=" + geojson + " --kml_out=" + kml + " --trajectory_out=" + traj +
          " --target_level_of_safety=1");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("plan on lux-demo: start (49."));
  EXPECT_THAT(r.output, HasSubstr("risk per flight hour"));
  EXPECT_THAT(r.output, HasSubstr("meets the target level of safety of 1 per flight hour"));
  EXPECT_THAT(r.output, HasSubstr("QGroundControl plan: " + plan));
  EXPECT_THAT(r.output, HasSubstr("GeoJSON: " + geojson));
  EXPECT_THAT(r.output, HasSubstr("KML: " + kml));

  // The plan's local waypoints start and end where the WGS84 request said.
  const Json waypoints = Json::parse(Read(traj))["waypoints"];
  ASSERT_GE(waypoints.size(), 2u);
  EXPECT_NEAR(waypoints.front()[0].get<double>(), start.x, kCentimetre);
  EXPECT_NEAR(waypoints.front()[1].get<double>(), start.y, kCentimetre);
  EXPECT_NEAR(waypoints.front()[3].get<double>(), start.theta, 1e-6);
  EXPECT_NEAR(waypoints.back()[0].get<double>(), goal.x, kCentimetre);
  EXPECT_NEAR(waypoints.back()[1].get<double>(), goal.y, kCentimetre);

  // The server's path of those waypoints, every 40 m, in both frames.
  v1::EvaluateRiskRequest request;
  request.set_map("lux-demo");
  for (const Json& w : waypoints) {
    v1::Pose* p = request.mutable_waypoints()->add_poses();
    p->set_x(w[0]);
    p->set_y(w[1]);
    p->set_z(w[2]);
    p->set_theta(w[3]);
  }
  request.set_path_spacing_m(40.0);
  v1::EvaluateRiskResponse path;
  ASSERT_TRUE(client_->EvaluateRisk(request, &path).ok());
  ASSERT_GE(path.path_size(), 10);
  EXPECT_GT(path.risk_per_flight_hour(), 0.0);
  EXPECT_DOUBLE_EQ(path.risk_per_flight_hour(), path.risk() / (path.length_m() / 18.0 / 3600.0));
  const int n = path.path_size();
  for (int k = 0; k < n; ++k) {
    ASSERT_TRUE(path.path(k).has_wgs84()) << k;
    // The server's two frames agree with each other.
    ExpectWithinACentimetre(path.path(k).wgs84().lat_deg(), path.path(k).wgs84().lon_deg(),
                            path.path(k).wgs84().alt_m(), path.path(k).pose(), "path");
  }

  // .plan: one NAV_WAYPOINT per path pose, the same doubles.
  const Json mission = Json::parse(Read(plan))["mission"];
  ASSERT_EQ(mission["items"].size(), static_cast<size_t>(n));
  for (int k = 0; k < n; ++k) {
    const Json& params = mission["items"][k]["params"];
    EXPECT_EQ(params[4].get<double>(), path.path(k).wgs84().lat_deg()) << k;
    EXPECT_EQ(params[5].get<double>(), path.path(k).wgs84().lon_deg()) << k;
    ExpectWithinACentimetre(params[4], params[5], params[6], path.path(k).pose(),
                            absl::StrFormat(".plan item %d", k));
  }
  ExpectWithinACentimetre(mission["items"][0]["params"][4], mission["items"][0]["params"][5],
                          mission["items"][0]["params"][6], request.waypoints().poses(0),
                          ".plan start");
  EXPECT_EQ(mission["cruiseSpeed"].get<double>(), 18.0);
  EXPECT_EQ(mission["vehicleType"], 1);

  // GeoJSON through OGR: the LineString's (lon, lat) and the altitudes.
  GDALAllRegister();
  {
    const char* drivers[] = {"GeoJSON", nullptr};
    std::unique_ptr<void, Closer> ds(
        GDALOpenEx(geojson.c_str(), GDAL_OF_VECTOR, drivers, nullptr, nullptr));
    ASSERT_NE(ds, nullptr);
    OGRLayerH layer = GDALDatasetGetLayer(ds.get(), 0);
    OGR_L_ResetReading(layer);
    OGRFeatureH line = OGR_L_GetNextFeature(layer);
    ASSERT_NE(line, nullptr);
    OGRGeometryH g = OGR_F_GetGeometryRef(line);
    ASSERT_EQ(OGR_G_GetPointCount(g), n);
    int count = 0;
    const double* alt =
        OGR_F_GetFieldAsDoubleList(line, OGR_F_GetFieldIndex(line, "alt_amsl_m"), &count);
    ASSERT_EQ(count, n);
    for (int k = 0; k < n; ++k) {
      ExpectWithinACentimetre(OGR_G_GetY(g, k), OGR_G_GetX(g, k), alt[k], path.path(k).pose(),
                              absl::StrFormat("GeoJSON point %d", k));
    }
    OGR_F_Destroy(line);
  }

  // KML through both of GDAL's drivers: (lon, lat, alt AMSL).
  for (const char* driver : {"KML", "LIBKML"}) {
    const char* drivers[] = {driver, nullptr};
    std::unique_ptr<void, Closer> ds(
        GDALOpenEx(kml.c_str(), GDAL_OF_VECTOR, drivers, nullptr, nullptr));
    ASSERT_NE(ds, nullptr) << driver;
    bool found = false;
    for (int l = 0; l < GDALDatasetGetLayerCount(ds.get()) && !found; ++l) {
      OGRLayerH layer = GDALDatasetGetLayer(ds.get(), l);
      OGR_L_ResetReading(layer);
      while (OGRFeatureH f = OGR_L_GetNextFeature(layer)) {
        OGRGeometryH g = OGR_F_GetGeometryRef(f);
        if (g != nullptr && wkbFlatten(OGR_G_GetGeometryType(g)) == wkbLineString) {
          found = true;
          EXPECT_EQ(OGR_G_GetPointCount(g), n) << driver;
          for (int k = 0; k < std::min(n, OGR_G_GetPointCount(g)); ++k) {
            ExpectWithinACentimetre(OGR_G_GetY(g, k), OGR_G_GetX(g, k), OGR_G_GetZ(g, k),
                                    path.path(k).pose(), absl::StrFormat("%s point %d", driver, k));
          }
        }
        OGR_F_Destroy(f);
      }
    }
    EXPECT_TRUE(found) << driver;
  }
}

TEST_F(GeoExportsTest, EvalInWgs84ReportsRiskPerFlightHourAgainstTheTarget) {
  const std::string waypoints =
      Wgs84Text({300, 375, 240, 0.785}) + ";" + Wgs84Text({1700, 1625, 250, 0.785}).substr(6);
  CommandResult r =
      Cli("eval --map=lux-demo --waypoints='" + waypoints + "' --target_level_of_safety=1e-15");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("does NOT meet the target level of safety of 1e-15"));
  r = Cli("eval --map=lux-demo --waypoints='" + waypoints + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("target level of safety of 1e-06 per flight hour"));
  // The same trajectory given in local metres has the same risk.
  CommandResult local =
      Cli("eval --json --map=lux-demo --waypoints='300,375,240,0.785; 1700,1625,250,0.785'");
  CommandResult geo = Cli("eval --json --map=lux-demo --waypoints='" + waypoints + "'");
  ASSERT_EQ(local.exit_code, 0) << local.output;
  ASSERT_EQ(geo.exit_code, 0) << geo.output;
  const Json a = Json::parse(local.output), b = Json::parse(geo.output);
  EXPECT_NEAR(b["risk"].get<double>(), a["risk"].get<double>(), 1e-6 * a["risk"].get<double>());
  EXPECT_NEAR(b["length_m"].get<double>(), a["length_m"].get<double>(), kCentimetre);
  EXPECT_EQ(a["flight_time_s"].get<double>(), a["length_m"].get<double>() / 18.0);
}

TEST_F(GeoExportsTest, MapsShowBothFrames) {
  v1::ListMapsResponse maps;
  ASSERT_TRUE(client_->ListMaps(&maps).ok());
  ASSERT_EQ(maps.maps_size(), 2);
  const v1::MapInfo& lux = maps.maps(0);
  ASSERT_EQ(lux.name(), "lux-demo");
  EXPECT_EQ(lux.geo().origin_lat_deg(), kLat0);
  EXPECT_EQ(lux.geo().origin_x_m(), 0.0);
  ASSERT_EQ(lux.bounds_wgs84().corners_size(), 4);
  EXPECT_DOUBLE_EQ(lux.bounds_wgs84().corners(0).lat_deg(), kLat0);
  const geo::LocalXY ne =
      Local(lux.bounds_wgs84().corners(2).lat_deg(), lux.bounds_wgs84().corners(2).lon_deg());
  EXPECT_NEAR(ne.x, 2000.0, kCentimetre);
  EXPECT_NEAR(ne.y, 2000.0, kCentimetre);
  EXPECT_FALSE(maps.maps(1).has_bounds_wgs84());
  CommandResult r = Cli("maps");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("geo-reference: local (0, 0) m is WGS84 (49.600000000, "
                                  "6.100000000) deg (test placement)"));
  EXPECT_THAT(r.output, HasSubstr("WGS84 extent: latitudes 49.5"));
}

TEST_F(GeoExportsTest, Wgs84OnAMapWithoutGeoReferenceIsRefusedNamingMapAndField) {
  CommandResult r =
      Cli("plan --map=plain --start=wgs84:49.6,6.1,240,45 "
          "--goal=1700,1625,250,0.785 --budget_ms=100");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_THAT(r.output, HasSubstr("INVALID_ARGUMENT: start_wgs84: map 'plain' has no "
                                  "geo-reference"));
  // Exports need WGS84: refused before the plan runs.
  r =
      Cli("plan --map=plain --start=300,375,240,0.785 --goal=1700,1625,250,0.785 "
          "--budget_ms=100 --plan_out=" +
          *dir_ + "/never.plan");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("map 'plain' has no geo-reference"));
  EXPECT_THAT(r.output, ::testing::Not(HasSubstr("(final)")));
  r = Cli("eval --map=plain --polyline='300,375,240; 1700,1625,250' --kml_out=" + *dir_ +
          "/never.kml");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("map 'plain' has no geo-reference"));
  r = Cli("plan --help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_THAT(r.output, HasSubstr("wgs84:"));
}

TEST_F(GeoExportsTest, GetRiskLayerIsTheToolsLayerAndTooLargeALayerIsRefused) {
  const std::string prefix = *dir_ + "/tool-layer";
  CommandResult tool = RunCommand(
      std::string(RISKPLAN_BIN_DIR) + "/riskplan-tool risk-layer --map=" + *dir_ +
      "/maps/lux-demo --out=" + prefix + " --agl_m=80 --heading_deg=max --stride=10 2>&1");
  ASSERT_EQ(tool.exit_code, 0) << tool.output;

  v1::GetRiskLayerRequest request;
  request.set_map("lux-demo");
  request.set_stride(10);
  request.set_height_agl_m(80.0);
  request.set_max_over_headings(true);
  v1::GetRiskLayerResponse layer;
  grpc::Status s = client_->GetRiskLayer(request, &layer);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(layer.nx(), 40);
  EXPECT_EQ(layer.ny(), 40);
  EXPECT_EQ(layer.cell_m(), 50.0);
  EXPECT_EQ(layer.evaluations(), 40 * 40 * 72);
  ASSERT_EQ(layer.bounds_wgs84().corners_size(), 4);

  GDALAllRegister();
  std::unique_ptr<void, Closer> ds(GDALOpen((prefix + ".tif").c_str(), GA_ReadOnly));
  ASSERT_NE(ds, nullptr);
  std::vector<double> tif(40 * 40);
  ASSERT_EQ(GDALRasterIO(GDALGetRasterBand(ds.get(), 1), GF_Read, 0, 0, 40, 40, tif.data(), 40, 40,
                         GDT_Float64, 0, 0),
            CE_None);
  int defined = 0;
  for (int row = 0; row < 40; ++row) {
    for (int c = 0; c < 40; ++c) {
      const double rpc = layer.risk((39 - row) * 40 + c);  // the RPC's row 0 is south
      const double file = tif[row * 40 + c];
      if (std::isnan(file)) {
        EXPECT_TRUE(std::isnan(rpc)) << row << ", " << c;
      } else {
        EXPECT_EQ(rpc, file) << row << ", " << c;
        ++defined;
      }
    }
  }
  EXPECT_GT(defined, 100);

  // A region: the same values where it overlaps.
  request.mutable_region()->set_x_min_m(500);
  request.mutable_region()->set_x_max_m(1000);
  request.mutable_region()->set_y_min_m(1000);
  request.mutable_region()->set_y_max_m(1500);
  v1::GetRiskLayerResponse part;
  ASSERT_TRUE(client_->GetRiskLayer(request, &part).ok());
  EXPECT_EQ(part.first_column(), 100);
  EXPECT_EQ(part.nx(), 10);
  EXPECT_EQ(part.x0_m(), 500.0);
  EXPECT_EQ(part.risk(0), layer.risk(20 * 40 + 10));

  // 400 x 400 cells at 72 heading bins is past --max_risk_layer_evaluations.
  request.clear_region();
  request.set_stride(1);
  s = client_->GetRiskLayer(request, &layer);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(s.error_message(),
              HasSubstr("the risk layer of 400 x 400 cells (stride 1) needs 11520000 "
                        "configuration risks (72 heading bins each)"));
}

// In wind: GetRiskLayer for a track heading is riskplan-tool's layer in the
// same wind bit for bit, and an evaluation's exports carry the wind and its
// flight time while their samples stay the ground track.
TEST_F(GeoExportsTest, InWindTheLayerIsTheToolsAndExportsCarryTheWind) {
  const std::string prefix = *dir_ + "/tool-layer-wind";
  CommandResult tool = RunCommand(std::string(RISKPLAN_BIN_DIR) +
                                  "/riskplan-tool risk-layer --map=" + *dir_ +
                                  "/maps/lux-demo --out=" + prefix +
                                  " --agl_m=80 --heading_deg=30 --stride=10 --wind=8@270 2>&1");
  ASSERT_EQ(tool.exit_code, 0) << tool.output;
  EXPECT_THAT(tool.output, HasSubstr("in a wind of 8 m/s from 270.0 deg"));
  v1::GetRiskLayerRequest request;
  request.set_map("lux-demo");
  request.set_stride(10);
  request.set_height_agl_m(80.0);
  request.set_heading_rad(30.0 * M_PI / 180.0);
  request.mutable_wind()->mutable_from()->set_speed_mps(8);
  request.mutable_wind()->mutable_from()->set_from_deg(270);
  v1::GetRiskLayerResponse layer;
  grpc::Status s = client_->GetRiskLayer(request, &layer);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(layer.wind().speed_mps(), 8.0);
  ASSERT_TRUE(layer.wind().has_from_true_deg());  // lux-demo has a geo-reference
  EXPECT_NEAR(layer.wind().from_true_deg(), 270.0, 0.1);
  GDALAllRegister();
  std::unique_ptr<void, Closer> ds(GDALOpen((prefix + ".tif").c_str(), GA_ReadOnly));
  ASSERT_NE(ds, nullptr);
  std::vector<double> tif(40 * 40);
  ASSERT_EQ(GDALRasterIO(GDALGetRasterBand(ds.get(), 1), GF_Read, 0, 0, 40, 40, tif.data(), 40, 40,
                         GDT_Float64, 0, 0),
            CE_None);
  int defined = 0;
  for (int row = 0; row < 40; ++row) {
    for (int c = 0; c < 40; ++c) {
      const double rpc = layer.risk((39 - row) * 40 + c);
      const double file = tif[row * 40 + c];
      if (std::isnan(file)) {
        EXPECT_TRUE(std::isnan(rpc)) << row << ", " << c;
      } else {
        EXPECT_EQ(rpc, file) << row << ", " << c;
        ++defined;
      }
    }
  }
  EXPECT_GT(defined, 100);

  const std::string geojson = *dir_ + "/wind.geojson";
  CommandResult r = Cli(
      "eval --map=lux-demo --wind=wgs84:6@90 --waypoints='300,375,240,0.785; "
      "1700,1625,250,0.785' --geojson_out=" +
      geojson);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("wind 6 m/s from "));
  EXPECT_THAT(r.output, HasSubstr("deg true)"));
  std::ifstream in(geojson);
  const Json j = Json::parse(in);
  const Json& properties = j["features"][0]["properties"];
  EXPECT_EQ(properties["wind_speed_mps"].get<double>(), 6.0);
  EXPECT_NEAR(properties["wind_from_true_deg"].get<double>(), 90.0, 1e-9);
  EXPECT_EQ(properties["airspeed_mps"].get<double>(), 18.0);
  EXPECT_NE(properties["flight_time_s"].get<double>(),
            properties["length_m"].get<double>() / 18.0);
}

}  // namespace
}  // namespace riskplan::testing
