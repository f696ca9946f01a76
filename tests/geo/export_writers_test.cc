// The ground-station and GIS writers, read back: the .plan field by field
// against QGroundControl's documented plan format, the GeoJSON against RFC
// 7946 and through GDAL/OGR, the KML through both of GDAL's KML drivers.
#include <gdal.h>
#include <ogr_api.h>
#include <ogrsf_frmts.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <string>

#include "geo/export/export_trajectory.h"
#include "geo/export/geojson.h"
#include "geo/export/kml.h"
#include "geo/export/qgc_plan.h"
#include "geo/export/xml_text.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "nlohmann/json.hpp"

namespace riskplan::geo {
namespace {

using ::testing::HasSubstr;
using Json = nlohmann::json;

// Three samples near Luxembourg, the second with an undefined risk.
ExportTrajectory Sample() {
  ExportTrajectory t;
  t.map = "lux-test";
  t.description = "a test <trajectory> & more";
  t.spacing_m = 50.0;
  t.risk = 2.5e-7;
  t.length_m = 100.25;
  t.flight_time_s = 100.25 / 18.0;
  t.risk_per_flight_hour = 2.5e-7 / (t.flight_time_s / 3600.0);
  t.airspeed_mps = 18.0;
  t.samples = {
      {49.612345678901, 6.123456789012, 330.125, 45.0, 0.0, 1.5e-8, true, 290.5},
      {49.612663330001, 6.123943210001, 331.5, 47.25, 50.0, 0.0, false, 291.0},
      {49.612980000002, 6.124430000003, 332.875, 49.5, 100.25, 3.25e-8, true, 292.25},
  };
  return t;
}

std::set<std::string> Keys(const Json& object) {
  std::set<std::string> keys;
  for (auto it = object.begin(); it != object.end(); ++it) keys.insert(it.key());
  return keys;
}

std::string TempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          ("riskplan_export_" + std::to_string(getpid()) + "_" + name))
      .string();
}

void WriteFile(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

// QGroundControl's plan format (docs.qgroundcontrol.com, "Plan File
// Format"): every key of every level, and the value riskplan gives it.
TEST(QgcPlanTest, EveryFieldIsTheDocumentedOne) {
  const ExportTrajectory t = Sample();
  absl::StatusOr<std::string> text = QgcPlanJson(t);
  ASSERT_TRUE(text.ok()) << text.status();
  const Json plan = Json::parse(*text);
  EXPECT_EQ(Keys(plan), (std::set<std::string>{"fileType", "version", "groundStation", "mission",
                                               "geoFence", "rallyPoints"}));
  EXPECT_EQ(plan["fileType"], "Plan");
  EXPECT_EQ(plan["version"], 1);
  EXPECT_EQ(plan["groundStation"], "riskplan");

  const Json& mission = plan["mission"];
  EXPECT_EQ(
      Keys(mission),
      (std::set<std::string>{"version", "firmwareType", "vehicleType", "cruiseSpeed", "hoverSpeed",
                             "globalPlanAltitudeMode", "plannedHomePosition", "items"}));
  EXPECT_EQ(mission["version"], 2);
  EXPECT_EQ(mission["firmwareType"], 12);  // MAV_AUTOPILOT_PX4
  EXPECT_EQ(mission["vehicleType"], 1);    // MAV_TYPE_FIXED_WING
  EXPECT_EQ(mission["cruiseSpeed"].get<double>(), 18.0);
  EXPECT_EQ(mission["hoverSpeed"].get<double>(), 5.0);
  EXPECT_EQ(mission["globalPlanAltitudeMode"], 2);  // AltitudeModeAbsolute
  // [latitude, longitude, AMSL altitude]: the ground under the start.
  ASSERT_EQ(mission["plannedHomePosition"].size(), 3u);
  EXPECT_EQ(mission["plannedHomePosition"][0].get<double>(), t.samples[0].lat_deg);
  EXPECT_EQ(mission["plannedHomePosition"][1].get<double>(), t.samples[0].lon_deg);
  EXPECT_EQ(mission["plannedHomePosition"][2].get<double>(), 290.5);

  const Json& items = mission["items"];
  ASSERT_TRUE(items.is_array());
  ASSERT_EQ(items.size(), t.samples.size());
  for (size_t k = 0; k < items.size(); ++k) {
    const Json& item = items[k];
    EXPECT_EQ(Keys(item), (std::set<std::string>{"type", "command", "frame", "params",
                                                 "autoContinue", "doJumpId", "AltitudeMode",
                                                 "Altitude", "AMSLAltAboveTerrain"}))
        << k;
    EXPECT_EQ(item["type"], "SimpleItem");
    EXPECT_EQ(item["command"], 16);  // MAV_CMD_NAV_WAYPOINT
    EXPECT_EQ(item["frame"], 0);     // MAV_FRAME_GLOBAL: altitude AMSL
    EXPECT_EQ(item["autoContinue"], true);
    EXPECT_EQ(item["doJumpId"], static_cast<int>(k) + 1);  // numbered from 1
    EXPECT_EQ(item["AltitudeMode"], 2);
    EXPECT_EQ(item["Altitude"].get<double>(), t.samples[k].alt_m);
    EXPECT_TRUE(item["AMSLAltAboveTerrain"].is_null());
    // MISSION_ITEM param1..4, x (lat), y (lon), z (alt): hold 0 s,
    // acceptance radius 0 (the autopilot's), pass radius 0 (through), yaw NaN
    // (written null, as QGroundControl writes NaN).
    const Json& params = item["params"];
    ASSERT_EQ(params.size(), 7u);
    EXPECT_EQ(params[0].get<double>(), 0.0);
    EXPECT_EQ(params[1].get<double>(), 0.0);
    EXPECT_EQ(params[2].get<double>(), 0.0);
    EXPECT_TRUE(params[3].is_null());
    // Shortest round-trip decimals: the very doubles come back.
    EXPECT_EQ(params[4].get<double>(), t.samples[k].lat_deg);
    EXPECT_EQ(params[5].get<double>(), t.samples[k].lon_deg);
    EXPECT_EQ(params[6].get<double>(), t.samples[k].alt_m);
  }
  EXPECT_EQ(plan["geoFence"],
            (Json{{"version", 2}, {"circles", Json::array()}, {"polygons", Json::array()}}));
  EXPECT_EQ(plan["rallyPoints"], (Json{{"version", 2}, {"points", Json::array()}}));
}

TEST(QgcPlanTest, OptionsAndFirmwareNames) {
  ExportTrajectory t = Sample();
  t.samples[0].terrain_m = std::numeric_limits<double>::quiet_NaN();
  QgcPlanOptions options;
  options.firmware_type = *FirmwareTypeFromName("ardupilot");
  options.acceptance_radius_m = 12.5;
  options.hold_s = 2.0;
  absl::StatusOr<std::string> text = QgcPlanJson(t, options);
  ASSERT_TRUE(text.ok()) << text.status();
  const Json plan = Json::parse(*text);
  EXPECT_EQ(plan["mission"]["firmwareType"], 3);
  // No terrain under the start: home at the start's own altitude.
  EXPECT_EQ(plan["mission"]["plannedHomePosition"][2].get<double>(), t.samples[0].alt_m);
  EXPECT_EQ(plan["mission"]["items"][1]["params"][0].get<double>(), 2.0);
  EXPECT_EQ(plan["mission"]["items"][1]["params"][1].get<double>(), 12.5);
  EXPECT_EQ(*FirmwareTypeFromName("px4"), 12);
  EXPECT_EQ(*FirmwareTypeFromName("generic"), 0);
  EXPECT_THAT(FirmwareTypeFromName("betaflight").status().message(), HasSubstr("px4"));
  options.pass_radius_m = -1.0;
  EXPECT_THAT(QgcPlanJson(t, options).status().message(), HasSubstr("pass_radius_m"));
}

TEST(ExportWritersTest, RefuseWhatCannotBeWrittenNamingIt) {
  ExportTrajectory t = Sample();
  t.samples.resize(1);
  EXPECT_THAT(QgcPlanJson(t).status().message(), HasSubstr("at least 2"));
  t = Sample();
  t.samples[2].lat_deg = 91.0;
  for (const absl::Status& s :
       {QgcPlanJson(t).status(), TrajectoryGeoJson(t).status(), TrajectoryKml(t).status()}) {
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
    EXPECT_THAT(s.message(), HasSubstr("sample 2"));
  }
  t = Sample();
  t.risk_per_flight_hour = std::numeric_limits<double>::infinity();
  EXPECT_THAT(TrajectoryGeoJson(t).status().message(), HasSubstr("risk_per_flight_hour"));
}

// RFC 7946: a FeatureCollection, positions [longitude, latitude], no "crs";
// the per-sample quantities as properties; JSON null where M is undefined.
TEST(GeoJsonTest, FollowsRfc7946AndCarriesEverySamplesRisk) {
  const ExportTrajectory t = Sample();
  absl::StatusOr<std::string> text = TrajectoryGeoJson(t);
  ASSERT_TRUE(text.ok()) << text.status();
  const Json doc = Json::parse(*text);
  EXPECT_EQ(doc["type"], "FeatureCollection");
  EXPECT_FALSE(doc.contains("crs"));
  ASSERT_EQ(doc["features"].size(), 1 + t.samples.size());
  const Json& line = doc["features"][0];
  EXPECT_EQ(line["type"], "Feature");
  EXPECT_EQ(line["geometry"]["type"], "LineString");
  const Json& coordinates = line["geometry"]["coordinates"];
  ASSERT_EQ(coordinates.size(), t.samples.size());
  for (size_t k = 0; k < t.samples.size(); ++k) {
    ASSERT_EQ(coordinates[k].size(), 2u);
    EXPECT_EQ(coordinates[k][0].get<double>(), t.samples[k].lon_deg);  // longitude first
    EXPECT_EQ(coordinates[k][1].get<double>(), t.samples[k].lat_deg);
    EXPECT_EQ(line["properties"]["alt_amsl_m"][k].get<double>(), t.samples[k].alt_m);
    EXPECT_EQ(line["properties"]["heading_deg"][k].get<double>(), t.samples[k].heading_deg);
    EXPECT_EQ(line["properties"]["arc_length_m"][k].get<double>(), t.samples[k].arc_length_m);
    const Json& risk = line["properties"]["sample_risk"][k];
    if (t.samples[k].risk_defined) {
      EXPECT_EQ(risk.get<double>(), t.samples[k].risk);
    } else {
      EXPECT_TRUE(risk.is_null());
    }
    const Json& point = doc["features"][k + 1];
    EXPECT_EQ(point["geometry"]["type"], "Point");
    EXPECT_EQ(point["properties"]["kind"], "sample");
    EXPECT_EQ(point["properties"]["index"], k);
    EXPECT_EQ(point["properties"]["risk"].is_null(), !t.samples[k].risk_defined);
  }
  const Json& p = line["properties"];
  EXPECT_EQ(p["kind"], "trajectory");
  EXPECT_EQ(p["map"], "lux-test");
  EXPECT_EQ(p["risk"].get<double>(), t.risk);
  EXPECT_EQ(p["risk_per_flight_hour"].get<double>(), t.risk_per_flight_hour);
  EXPECT_EQ(p["flight_time_s"].get<double>(), t.flight_time_s);
}

struct DatasetCloser {
  void operator()(GDALDatasetH d) const { GDALClose(d); }
};
using Dataset = std::unique_ptr<void, DatasetCloser>;

Dataset OpenVector(const std::string& path, const char* driver) {
  GDALAllRegister();
  const char* drivers[] = {driver, nullptr};
  return Dataset(
      GDALOpenEx(path.c_str(), GDAL_OF_VECTOR | GDAL_OF_READONLY, drivers, nullptr, nullptr));
}

TEST(GeoJsonTest, GdalReadsThePointsBack) {
  const ExportTrajectory t = Sample();
  const std::string path = TempPath("trajectory.geojson");
  WriteFile(path, *TrajectoryGeoJson(t));
  Dataset ds = OpenVector(path, "GeoJSON");
  ASSERT_NE(ds, nullptr) << CPLGetLastErrorMsg();
  OGRLayerH layer = GDALDatasetGetLayer(ds.get(), 0);
  ASSERT_NE(layer, nullptr);
  EXPECT_EQ(OGR_L_GetFeatureCount(layer, TRUE), static_cast<GIntBig>(1 + t.samples.size()));
  // The CRS GDAL reports for RFC 7946 GeoJSON is WGS84 (OGC:CRS84 order).
  OGRSpatialReferenceH srs = OGR_L_GetSpatialRef(layer);
  ASSERT_NE(srs, nullptr);
  EXPECT_TRUE(OSRIsGeographic(srs));
  OGR_L_ResetReading(layer);
  OGRFeatureH line = OGR_L_GetNextFeature(layer);
  ASSERT_NE(line, nullptr);
  OGRGeometryH g = OGR_F_GetGeometryRef(line);
  ASSERT_EQ(wkbFlatten(OGR_G_GetGeometryType(g)), wkbLineString);
  ASSERT_EQ(OGR_G_GetPointCount(g), static_cast<int>(t.samples.size()));
  const int alt_field = OGR_F_GetFieldIndex(line, "alt_amsl_m");
  ASSERT_GE(alt_field, 0);
  int count = 0;
  const double* alts = OGR_F_GetFieldAsDoubleList(line, alt_field, &count);
  ASSERT_EQ(count, static_cast<int>(t.samples.size()));
  for (int k = 0; k < count; ++k) {
    EXPECT_EQ(OGR_G_GetX(g, k), t.samples[k].lon_deg);
    EXPECT_EQ(OGR_G_GetY(g, k), t.samples[k].lat_deg);
    EXPECT_EQ(alts[k], t.samples[k].alt_m);
  }
  OGR_F_Destroy(line);
  std::filesystem::remove(path);
}

// KML's coordinates are longitude, latitude, altitude AMSL (altitudeMode
// absolute), written to 1e-10 degrees (about 0.01 mm) and 0.1 mm.
TEST(XmlEscapeTest, EscapesTheFiveMeaningfulCharactersAndKeepsEveryOtherByte) {
  EXPECT_EQ(XmlEscape(R"(<a href="x">Tom & Jerry's</a>)"),
            "&lt;a href=&quot;x&quot;&gt;Tom &amp; Jerry&apos;s&lt;/a&gt;");
  // Already escaped text is escaped again (the writers take plain text).
  EXPECT_EQ(XmlEscape("&amp;"), "&amp;amp;");
  const std::string bytes("depot \xc3\xa9 \0 end", 14);
  EXPECT_EQ(XmlEscape(bytes), bytes);
  EXPECT_EQ(XmlEscape(""), "");
}

TEST(KmlTest, BothGdalDriversReadTheLineBack) {
  const ExportTrajectory t = Sample();
  absl::StatusOr<std::string> text = TrajectoryKml(t);
  ASSERT_TRUE(text.ok()) << text.status();
  EXPECT_THAT(*text, HasSubstr("&lt;trajectory&gt; &amp; more"));
  EXPECT_THAT(*text, HasSubstr("<altitudeMode>absolute</altitudeMode>"));
  const std::string path = TempPath("trajectory.kml");
  WriteFile(path, *text);
  for (const char* driver : {"KML", "LIBKML"}) {
    Dataset ds = OpenVector(path, driver);
    ASSERT_NE(ds, nullptr) << driver << ": " << CPLGetLastErrorMsg();
    bool found_line = false;
    int points = 0;
    for (int l = 0; l < GDALDatasetGetLayerCount(ds.get()); ++l) {
      OGRLayerH layer = GDALDatasetGetLayer(ds.get(), l);
      OGR_L_ResetReading(layer);
      while (OGRFeatureH f = OGR_L_GetNextFeature(layer)) {
        OGRGeometryH g = OGR_F_GetGeometryRef(f);
        if (g != nullptr && wkbFlatten(OGR_G_GetGeometryType(g)) == wkbLineString) {
          found_line = true;
          ASSERT_EQ(OGR_G_GetPointCount(g), static_cast<int>(t.samples.size())) << driver;
          for (int k = 0; k < OGR_G_GetPointCount(g); ++k) {
            EXPECT_NEAR(OGR_G_GetX(g, k), t.samples[k].lon_deg, 1e-10) << driver << " " << k;
            EXPECT_NEAR(OGR_G_GetY(g, k), t.samples[k].lat_deg, 1e-10) << driver << " " << k;
            EXPECT_NEAR(OGR_G_GetZ(g, k), t.samples[k].alt_m, 1e-4) << driver << " " << k;
          }
        } else if (g != nullptr && wkbFlatten(OGR_G_GetGeometryType(g)) == wkbPoint) {
          ++points;
        }
        OGR_F_Destroy(f);
      }
    }
    EXPECT_TRUE(found_line) << driver;
    EXPECT_EQ(points, static_cast<int>(t.samples.size())) << driver;
  }
  std::filesystem::remove(path);
}

TEST(ExportWritersTest, WritesFilesAtomically) {
  const std::string path = TempPath("atomic.txt");
  ASSERT_TRUE(WriteTextFileAtomically("first", path).ok());
  ASSERT_TRUE(WriteTextFileAtomically("second", path).ok());
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(), "second");
  std::filesystem::remove(path);
  absl::Status s = WriteTextFileAtomically("x", "/nonexistent-dir/file.plan");
  EXPECT_EQ(s.code(), absl::StatusCode::kUnavailable);
  EXPECT_THAT(s.message(), HasSubstr("/nonexistent-dir/file.plan"));
}

}  // namespace
}  // namespace riskplan::geo
