#include "geo/export/geojson.h"

#include <cmath>

#include "nlohmann/json.hpp"

namespace riskplan::geo {
namespace {

using Json = nlohmann::ordered_json;

// JSON has no NaN: an undefined value is null.
Json NumberOrNull(double value, bool defined = true) {
  if (!defined || !std::isfinite(value)) return nullptr;
  return value;
}

}  // namespace

absl::StatusOr<std::string> TrajectoryGeoJson(const ExportTrajectory& t) {
  if (absl::Status s = CheckExportTrajectory(t); !s.ok()) return s;
  Json coordinates = Json::array();
  Json alt = Json::array(), heading = Json::array(), arc = Json::array(), risk = Json::array();
  Json features = Json::array();
  // Positions are [longitude, latitude] with no third element: RFC 7946
  // makes it the height above the WGS84 ellipsoid, and riskplan's altitudes
  // are above mean sea level, so they go in the alt_amsl_m properties.
  for (const ExportSample& s : t.samples) {
    coordinates.push_back({s.lon_deg, s.lat_deg});
    alt.push_back(s.alt_m);
    heading.push_back(s.heading_deg);
    arc.push_back(s.arc_length_m);
    risk.push_back(NumberOrNull(s.risk, s.risk_defined));
  }
  features.push_back({
      {"type", "Feature"},
      {"geometry", {{"type", "LineString"}, {"coordinates", std::move(coordinates)}}},
      {"properties",
       {
           {"kind", "trajectory"},
           {"map", t.map},
           {"description", t.description},
           {"risk", t.risk},
           {"length_m", t.length_m},
           {"flight_time_s", t.flight_time_s},
           {"risk_per_flight_hour", t.risk_per_flight_hour},
           {"airspeed_mps", t.airspeed_mps},
           {"spacing_m", t.spacing_m},
           {"alt_amsl_m", std::move(alt)},
           {"heading_deg", std::move(heading)},
           {"arc_length_m", std::move(arc)},
           {"sample_risk", std::move(risk)},
       }},
  });
  if (t.wind_speed_mps > 0.0) {
    Json& properties = features.back()["properties"];
    properties["wind_speed_mps"] = t.wind_speed_mps;
    properties["wind_from_true_deg"] = t.wind_from_true_deg;
  }
  for (size_t k = 0; k < t.samples.size(); ++k) {
    const ExportSample& s = t.samples[k];
    features.push_back({
        {"type", "Feature"},
        {"geometry", {{"type", "Point"}, {"coordinates", {s.lon_deg, s.lat_deg}}}},
        {"properties",
         {
             {"kind", "sample"},
             {"index", static_cast<int64_t>(k)},
             {"alt_amsl_m", s.alt_m},
             {"heading_deg", s.heading_deg},
             {"arc_length_m", s.arc_length_m},
             {"risk", NumberOrNull(s.risk, s.risk_defined)},
             {"terrain_m", NumberOrNull(s.terrain_m)},
         }},
    });
  }
  const Json collection = {
      {"type", "FeatureCollection"},
      {"features", std::move(features)},
  };
  return collection.dump(1) + "\n";
}

}  // namespace riskplan::geo
