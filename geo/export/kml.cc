#include "geo/export/kml.h"

#include <cmath>
#include <string>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "geo/export/xml_text.h"

namespace riskplan::geo {
namespace {

// 10 decimals of a degree (about 0.01 mm) and 4 of a metre. KML's absolute
// altitudes are above sea level, as riskplan's are.
std::string Coordinates(const ExportSample& s) {
  return absl::StrFormat("%.10f,%.10f,%.4f", s.lon_deg, s.lat_deg, s.alt_m);
}

// A number with every digit a double holds; "" when undefined.
std::string Number(double value, bool defined = true) {
  if (!defined || !std::isfinite(value)) return "";
  return absl::StrFormat("%.17g", value);
}

void AppendData(std::string* out, const char* name, const std::string& value) {
  absl::StrAppend(out, "<Data name=\"", name, "\"><value>", value, "</value></Data>");
}

}  // namespace

absl::StatusOr<std::string> TrajectoryKml(const ExportTrajectory& t) {
  if (absl::Status s = CheckExportTrajectory(t); !s.ok()) return s;
  std::string out =
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<kml xmlns=\"http://www.opengis.net/kml/2.2\">\n"
      "<Document>\n";
  absl::StrAppend(&out, "<name>riskplan trajectory on ", XmlEscape(t.map), "</name>\n");
  absl::StrAppend(&out, "<description>", XmlEscape(t.description), "</description>\n");
  absl::StrAppend(&out,
                  "<Style id=\"trajectory\"><LineStyle><color>ff0000ff</color><width>3</width>"
                  "</LineStyle></Style>\n");
  absl::StrAppend(&out, "<Placemark>\n<name>trajectory</name>\n<styleUrl>#trajectory</styleUrl>\n",
                  "<ExtendedData>");
  AppendData(&out, "risk", Number(t.risk));
  AppendData(&out, "length_m", Number(t.length_m));
  AppendData(&out, "flight_time_s", Number(t.flight_time_s));
  AppendData(&out, "risk_per_flight_hour", Number(t.risk_per_flight_hour));
  AppendData(&out, "airspeed_mps", Number(t.airspeed_mps));
  if (t.wind_speed_mps > 0.0) {
    AppendData(&out, "wind_speed_mps", Number(t.wind_speed_mps));
    AppendData(&out, "wind_from_true_deg", Number(t.wind_from_true_deg));
  }
  AppendData(&out, "spacing_m", Number(t.spacing_m));
  absl::StrAppend(&out, "</ExtendedData>\n<LineString>\n<altitudeMode>absolute</altitudeMode>\n",
                  "<coordinates>\n");
  for (const ExportSample& s : t.samples) absl::StrAppend(&out, Coordinates(s), "\n");
  absl::StrAppend(&out, "</coordinates>\n</LineString>\n</Placemark>\n");
  absl::StrAppend(&out, "<Folder>\n<name>samples</name>\n");
  for (size_t k = 0; k < t.samples.size(); ++k) {
    const ExportSample& s = t.samples[k];
    absl::StrAppend(&out, "<Placemark><name>", k, "</name><ExtendedData>");
    AppendData(&out, "index", absl::StrCat(k));
    AppendData(&out, "heading_deg", Number(s.heading_deg));
    AppendData(&out, "arc_length_m", Number(s.arc_length_m));
    AppendData(&out, "risk", Number(s.risk, s.risk_defined));
    AppendData(&out, "terrain_m", Number(s.terrain_m));
    absl::StrAppend(&out,
                    "</ExtendedData><Point><altitudeMode>absolute</altitudeMode><coordinates>",
                    Coordinates(s), "</coordinates></Point></Placemark>\n");
  }
  absl::StrAppend(&out, "</Folder>\n</Document>\n</kml>\n");
  return out;
}

}  // namespace riskplan::geo
