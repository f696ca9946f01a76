// Text forms of poses and trajectories for the CLI, parsed straight into API
// messages (the client does not depend on core/). Same forms as
// riskplan-tool:
//   pose:      "x,y,z,theta"                      (m, m, m AMSL, rad)
//   wind:      "SPEED@FROM_DEG"                   (m/s, deg clockwise from
//                                                 the map's grid north the
//                                                 wind blows from)
//   waypoints: "x,y,z,theta; x,y,z,theta; ..."
//   polyline:  "x,y,z; x,y,z; ..."
//   JSON file: {"waypoints": [[x, y, z, theta], ...]} or
//              {"polyline": [[x, y, z], ...]}
// On a geo-referenced map the same forms may be given in WGS84 by starting
// the text with "wgs84:", which applies to every point of the text:
//   pose:      "wgs84:lat,lon,alt,heading_deg"   (deg, deg, m AMSL, deg
//                                                 clockwise from true north)
//   waypoints: "wgs84:lat,lon,alt,heading_deg; lat,lon,alt,heading_deg; ..."
//   polyline:  "wgs84:lat,lon,alt; lat,lon,alt; ..."
//   obstacles: "wgs84:lat,lon; lat,lon; ..."
//   wind:      "wgs84:SPEED@FROM_DEG"              (m/s, deg clockwise
//                                                 from true north)
// (latitude first, as ground stations write it). Without the prefix a text is
// in the map's local metres, as before: a bare list of numbers never changes
// its meaning.
// The text forms' parsers check the syntax and that every number is finite;
// ranges and admissibility are the server's business. Errors
// (InvalidArgument) name the point index and the text at fault.
#ifndef RISKPLAN_CLIENT_TRAJECTORY_TEXT_H_
#define RISKPLAN_CLIENT_TRAJECTORY_TEXT_H_

#include <cstddef>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "formats/trajectory_json.h"
#include "riskplan/v1/planner.pb.h"

namespace riskplan::client {

// The prefix that puts a text form in WGS84.
inline constexpr std::string_view kWgs84Prefix = "wgs84:";

// Whether `text` (after leading blanks) starts with kWgs84Prefix; `rest` is
// set to what follows it (or to the whole text when it does not).
bool HasWgs84Prefix(std::string_view text, std::string_view* rest);

absl::StatusOr<v1::Pose> ParsePose(std::string_view text);
// "lat,lon,alt,heading_deg" (without the prefix).
absl::StatusOr<v1::GeoPose> ParseGeoPose(std::string_view text);
// "lat,lon,alt,heading_deg; ..." and "lat,lon,alt; ..." (without the
// prefix), at least 2 points; "lat,lon; ..." (any number).
absl::StatusOr<v1::GeoWaypoints> ParseGeoWaypoints(std::string_view text);
absl::StatusOr<v1::GeoPolyline> ParseGeoPolyline(std::string_view text);
absl::StatusOr<std::vector<v1::GeoPoint2>> ParseGeoPoints2(std::string_view text);
absl::StatusOr<v1::Waypoints> ParseWaypoints(std::string_view text);
absl::StatusOr<v1::Polyline> ParsePolyline(std::string_view text);
// "x,y; x,y; ..." (any number of points, none for empty text).
absl::StatusOr<std::vector<v1::Point2>> ParsePoints2(std::string_view text);

// Trajectory JSON, by the rule of docs/api.md ("Trajectory files"), parsed
// by formats/trajectory_json.h as riskplan-tool's reader
// (core/flight/trajectory_io.h) parses it, which the client may not use;
// tests/data/trajectory_json_cases.json is the one table of cases both are
// tested against. The limits are riskplan-tool's, so that a file one tool
// reads the other reads too.
inline constexpr size_t kMaxTrajectoryJsonPoints = formats::kMaxTrajectoryJsonPoints;
inline constexpr size_t kMaxTrajectoryFileBytes = formats::kMaxTrajectoryFileBytes;

// Sets the trajectory of `request` (waypoints or polyline) from JSON text;
// on error `request` is left unchanged. Errors are InvalidArgument: the
// prefix "trajectory JSON: ", then the JSON path at fault and what is wrong,
// e.g. `waypoints[3].theta must be a number, got string "1.57"`.
// REQUIRES: request != nullptr.
absl::Status ParseTrajectoryJson(std::string_view json, v1::EvaluateRiskRequest* request);
// The same from a file of at most kMaxTrajectoryFileBytes; errors in its
// content start with "trajectory file 'PATH': " instead. A file that cannot
// be opened or read is NotFound ("cannot open trajectory file 'PATH': ...").
// REQUIRES: request != nullptr.
absl::Status ReadTrajectoryFile(const std::string& path, v1::EvaluateRiskRequest* request);

// JSON text {"waypoints": [[x, y, z, theta], ...]} of a trajectory, which
// ReadTrajectoryFile reads back.
std::string WaypointsToJson(const google::protobuf::RepeatedPtrField<v1::Pose>& poses);

// A wind "SPEED@FROM_DEG" (e.g. "8@270", a west wind of 8 m/s): a speed
// >= 0 and a finite direction (any; the server takes it modulo 360), both
// plain numbers; with the prefix "wgs84:" the direction is from true north
// and the wind goes into `wind_wgs84`. Sets exactly one of `*wind` and
// `*wind_wgs84` (both left unchanged on error). Errors name `flag` and the
// text, e.g. "--wind='8' is not SPEED@FROM_DEG (m/s @ degrees clockwise
// from north the wind blows from, e.g. 8@270)". REQUIRES: non-null outputs.
absl::Status ParseWind(std::string_view text, std::string_view flag, v1::Wind* wind,
                       v1::GeoWind* wind_wgs84, bool* is_wgs84);

// "name=value,name=value" into a map (values finite). Empty text: empty map.
absl::StatusOr<std::map<std::string, double>> ParseNameValues(std::string_view text);

// Applies "name=value,..." to ModelParameters by field name (proto
// reflection); errors name the unknown field and list the known ones.
// REQUIRES: params != nullptr.
absl::Status ParseModelParameters(std::string_view text, v1::ModelParameters* params);

}  // namespace riskplan::client

#endif  // RISKPLAN_CLIENT_TRAJECTORY_TEXT_H_
