#include "client/trajectory_text.h"

#include <cassert>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <span>
#include <utility>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "google/protobuf/descriptor.h"
#include "google/protobuf/reflection.h"
#include "nlohmann/json.hpp"

namespace riskplan::client {
namespace {

// Splits "a,b,c" into exactly `count` finite numbers. SimpleAtod accepts
// "nan" and "inf", which the server would refuse only after a round trip and
// without naming the flag, hence the finiteness check here. (Debian's abseil
// has its own absl::string_view, not an alias of std::string_view, so text
// crosses into abseil as absl::string_view.)
absl::StatusOr<std::vector<double>> ParseNumbers(std::string_view text, size_t count,
                                                 std::string_view what) {
  std::vector<double> out;
  for (absl::string_view part : absl::StrSplit(absl::string_view(text.data(), text.size()), ',')) {
    double value = 0.0;
    if (!absl::SimpleAtod(absl::StripAsciiWhitespace(part), &value) || !std::isfinite(value)) {
      return absl::InvalidArgumentError(absl::StrFormat("%s '%s': '%s' is not a finite number",
                                                        std::string(what), std::string(text),
                                                        std::string(part)));
    }
    out.push_back(value);
  }
  if (out.size() != count) {
    return absl::InvalidArgumentError(absl::StrFormat("%s '%s' has %d numbers; expected %d",
                                                      std::string(what), std::string(text),
                                                      out.size(), count));
  }
  return out;
}

// The ';'-separated points, blank ones skipped, so that a trailing ';' (easy
// to leave when pasting a list) is not an empty point.
std::vector<std::string> Points(std::string_view text) {
  std::vector<std::string> points;
  for (absl::string_view part :
       absl::StrSplit(absl::string_view(text.data(), text.size()), ';', absl::SkipWhitespace())) {
    points.emplace_back(absl::StripAsciiWhitespace(part));
  }
  return points;
}

}  // namespace

bool HasWgs84Prefix(std::string_view text, std::string_view* rest) {
  const size_t start = text.find_first_not_of(" \t");
  if (start != std::string_view::npos && text.substr(start, kWgs84Prefix.size()) == kWgs84Prefix) {
    *rest = text.substr(start + kWgs84Prefix.size());
    return true;
  }
  *rest = text;
  return false;
}

absl::StatusOr<v1::GeoPose> ParseGeoPose(std::string_view text) {
  absl::StatusOr<std::vector<double>> v = ParseNumbers(text, 4, "WGS84 pose (lat,lon,alt,heading)");
  if (!v.ok()) return v.status();
  v1::GeoPose pose;
  pose.set_lat_deg((*v)[0]);
  pose.set_lon_deg((*v)[1]);
  pose.set_alt_m((*v)[2]);
  pose.set_heading_deg((*v)[3]);
  return pose;
}

absl::StatusOr<v1::GeoWaypoints> ParseGeoWaypoints(std::string_view text) {
  v1::GeoWaypoints out;
  const std::vector<std::string> points = Points(text);
  for (size_t i = 0; i < points.size(); ++i) {
    absl::StatusOr<std::vector<double>> v =
        ParseNumbers(points[i], 4, absl::StrFormat("WGS84 waypoint %d (lat,lon,alt,heading)", i));
    if (!v.ok()) return v.status();
    v1::GeoPose* pose = out.add_poses();
    pose->set_lat_deg((*v)[0]);
    pose->set_lon_deg((*v)[1]);
    pose->set_alt_m((*v)[2]);
    pose->set_heading_deg((*v)[3]);
  }
  if (out.poses_size() < 2) {
    return absl::InvalidArgumentError(
        absl::StrFormat("waypoints: %d given; at least 2 are needed", out.poses_size()));
  }
  return out;
}

absl::StatusOr<v1::GeoPolyline> ParseGeoPolyline(std::string_view text) {
  v1::GeoPolyline out;
  const std::vector<std::string> points = Points(text);
  for (size_t i = 0; i < points.size(); ++i) {
    absl::StatusOr<std::vector<double>> v =
        ParseNumbers(points[i], 3, absl::StrFormat("WGS84 polyline point %d (lat,lon,alt)", i));
    if (!v.ok()) return v.status();
    v1::GeoPoint3* p = out.add_points();
    p->set_lat_deg((*v)[0]);
    p->set_lon_deg((*v)[1]);
    p->set_alt_m((*v)[2]);
  }
  if (out.points_size() < 2) {
    return absl::InvalidArgumentError(
        absl::StrFormat("polyline: %d points given; at least 2 are needed", out.points_size()));
  }
  return out;
}

absl::StatusOr<std::vector<v1::GeoPoint2>> ParseGeoPoints2(std::string_view text) {
  std::vector<v1::GeoPoint2> out;
  const std::vector<std::string> points = Points(text);
  for (size_t i = 0; i < points.size(); ++i) {
    absl::StatusOr<std::vector<double>> v =
        ParseNumbers(points[i], 2, absl::StrFormat("WGS84 obstacle %d (lat,lon)", i));
    if (!v.ok()) return v.status();
    v1::GeoPoint2& p = out.emplace_back();
    p.set_lat_deg((*v)[0]);
    p.set_lon_deg((*v)[1]);
  }
  return out;
}

absl::StatusOr<v1::Pose> ParsePose(std::string_view text) {
  absl::StatusOr<std::vector<double>> v = ParseNumbers(text, 4, "pose");
  if (!v.ok()) return v.status();
  v1::Pose pose;
  pose.set_x((*v)[0]);
  pose.set_y((*v)[1]);
  pose.set_z((*v)[2]);
  pose.set_theta((*v)[3]);
  return pose;
}

absl::StatusOr<v1::Waypoints> ParseWaypoints(std::string_view text) {
  v1::Waypoints out;
  const std::vector<std::string> points = Points(text);
  for (size_t i = 0; i < points.size(); ++i) {
    absl::StatusOr<std::vector<double>> v =
        ParseNumbers(points[i], 4, absl::StrFormat("waypoint %d", i));
    if (!v.ok()) return v.status();
    v1::Pose* pose = out.add_poses();
    pose->set_x((*v)[0]);
    pose->set_y((*v)[1]);
    pose->set_z((*v)[2]);
    pose->set_theta((*v)[3]);
  }
  // A trajectory needs two points; the server checks it too, but here the
  // message can name the flag.
  if (out.poses_size() < 2) {
    return absl::InvalidArgumentError(
        absl::StrFormat("waypoints: %d given; at least 2 are needed", out.poses_size()));
  }
  return out;
}

absl::StatusOr<v1::Polyline> ParsePolyline(std::string_view text) {
  v1::Polyline out;
  const std::vector<std::string> points = Points(text);
  for (size_t i = 0; i < points.size(); ++i) {
    absl::StatusOr<std::vector<double>> v =
        ParseNumbers(points[i], 3, absl::StrFormat("polyline point %d", i));
    if (!v.ok()) return v.status();
    v1::Point3* p = out.add_points();
    p->set_x((*v)[0]);
    p->set_y((*v)[1]);
    p->set_z((*v)[2]);
  }
  if (out.points_size() < 2) {
    return absl::InvalidArgumentError(
        absl::StrFormat("polyline: %d points given; at least 2 are needed", out.points_size()));
  }
  return out;
}

// Unlike a trajectory, an obstacle list may be empty: --obstacles is optional.
absl::StatusOr<std::vector<v1::Point2>> ParsePoints2(std::string_view text) {
  std::vector<v1::Point2> out;
  const std::vector<std::string> points = Points(text);
  for (size_t i = 0; i < points.size(); ++i) {
    absl::StatusOr<std::vector<double>> v =
        ParseNumbers(points[i], 2, absl::StrFormat("obstacle %d", i));
    if (!v.ok()) return v.status();
    v1::Point2& p = out.emplace_back();
    p.set_x((*v)[0]);
    p.set_y((*v)[1]);
  }
  return out;
}

namespace {

// The trajectory JSON rule of docs/api.md ("Trajectory files"), written again
// here because the client may not use core's ParseTrajectoryJson
// (core/flight/trajectory_io.cc). Keep the two in step:
// tests/data/trajectory_json_cases.json is the one table of cases both are
// tested against.

using Json = nlohmann::json;

constexpr const char* kWaypointFields[] = {"x", "y", "z", "theta"};
constexpr const char* kPolylineFields[] = {"x", "y", "z"};
static_assert(std::size(kWaypointFields) == 4 && std::size(kPolylineFields) == 3);

// A JSON string or scalar as it would be written, in ASCII (so that cutting it
// cannot split a UTF-8 sequence) and cut to 40 characters: an error message
// shows enough of the value to find it, not a whole file.
std::string Shown(const Json& value) {
  std::string text = value.dump(-1, ' ', /*ensure_ascii=*/true);
  if (text.size() > 40) text = text.substr(0, 37) + "...";
  return text;
}

// "got object", "got string \"1.57\"", "got boolean true": the JSON type
// found, and the value too when it is short enough to help.
std::string Got(const Json& value) {
  if (value.is_string() || value.is_boolean()) {
    return absl::StrFormat("got %s %s", value.type_name(), Shown(value));
  }
  return absl::StrFormat("got %s", value.type_name());
}

std::string Plural(size_t n, const char* word) {
  return absl::StrFormat("%d %s%s", n, word, n == 1 ? "" : "s");
}

// Sets the trajectory of `request` only once the whole text has passed, so a
// refused file leaves the request as it was.
absl::Status ParseJson(std::string_view json, const std::string& context,
                       v1::EvaluateRiskRequest* request) {
  auto invalid = [&context](const std::string& detail) {
    return absl::InvalidArgumentError(absl::StrFormat("%s: %s", context, detail));
  };
  // nlohmann::json keeps only the last value of a repeated key, so a second
  // "waypoints" would silently replace the first: repeats are caught here,
  // while parsing. Depth 1 is the top-level object, the only one the rule
  // allows.
  std::set<std::string> keys;
  std::string repeated;
  Json doc;
  try {
    doc = Json::parse(json.begin(), json.end(),
                      [&](int depth, Json::parse_event_t event, Json& parsed) {
                        if (event == Json::parse_event_t::key && depth == 1 &&
                            !keys.insert(parsed.get<std::string>()).second && repeated.empty()) {
                          repeated = parsed.get<std::string>();
                        }
                        return true;
                      });
  } catch (const Json::exception& e) {
    // Only the exception carries the line and column of a syntax error; it is
    // caught right here. nlohmann's "[json.exception.parse_error.101] " tag
    // means nothing to a user and is dropped.
    std::string what = e.what();
    if (size_t close = what.find("] ");
        what.rfind("[json.exception", 0) == 0 && close != std::string::npos) {
      what = what.substr(close + 2);
    }
    return invalid("not valid JSON: " + what);
  }
  if (!doc.is_object()) {
    return invalid(absl::StrFormat("the top level must be an object, %s", Got(doc)));
  }
  if (!repeated.empty()) {
    return invalid(absl::StrFormat("key %s appears twice", Shown(Json(repeated))));
  }
  // Unknown keys are refused rather than ignored: a key such as "units" or
  // "frame" that this reader does not know could change what the numbers
  // mean, and a misspelt key would otherwise go unnoticed.
  for (const auto& [key, value] : doc.items()) {
    if (key != "waypoints" && key != "polyline") {
      return invalid(absl::StrFormat(
          "unknown key %s; the only keys are \"waypoints\" and \"polyline\"", Shown(Json(key))));
    }
  }
  const bool has_waypoints = doc.contains("waypoints");
  const bool has_polyline = doc.contains("polyline");
  if (has_waypoints == has_polyline) {
    return invalid(absl::StrFormat("needs exactly one of \"waypoints\" and \"polyline\", got %s",
                                   has_waypoints ? "both" : "neither"));
  }
  const char* key = has_waypoints ? "waypoints" : "polyline";
  const std::span<const char* const> fields = has_waypoints
                                                  ? std::span<const char* const>(kWaypointFields)
                                                  : std::span<const char* const>(kPolylineFields);
  const std::string shape = absl::StrFormat("[%s]", absl::StrJoin(fields, ", "));
  const Json& list = doc.at(key);
  if (!list.is_array()) return invalid(absl::StrFormat("%s must be an array, %s", key, Got(list)));
  // The server refuses fewer than 2 points too, and by default more than
  // 10 000 (--max_waypoints); the upper bound here is riskplan-tool's, so
  // that one file is accepted or refused alike by both tools.
  if (list.size() < 2) {
    return invalid(absl::StrFormat("%s has %s; a trajectory needs at least 2", key,
                                   Plural(list.size(), "point")));
  }
  if (list.size() > kMaxTrajectoryJsonPoints) {
    return invalid(absl::StrFormat("%s has %s; at most %d are accepted", key,
                                   Plural(list.size(), "point"), kMaxTrajectoryJsonPoints));
  }
  v1::Waypoints waypoints;
  v1::Polyline polyline;
  for (size_t i = 0; i < list.size(); ++i) {
    const Json& item = list[i];
    if (!item.is_array()) {
      return invalid(absl::StrFormat("%s[%d] must be an array %s, %s", key, i, shape, Got(item)));
    }
    if (item.size() != fields.size()) {
      return invalid(absl::StrFormat("%s[%d] has %s; expected %d: %s", key, i,
                                     Plural(item.size(), "value"), fields.size(), shape));
    }
    double v[4] = {0, 0, 0, 0};
    for (size_t k = 0; k < fields.size(); ++k) {
      // JSON has no NaN or infinity, and nlohmann refuses a number beyond the
      // range of a double as a parse error, so every number here is finite.
      if (!item[k].is_number()) {
        return invalid(
            absl::StrFormat("%s[%d].%s must be a number, %s", key, i, fields[k], Got(item[k])));
      }
      v[k] = item[k].get<double>();
    }
    if (has_waypoints) {
      v1::Pose* pose = waypoints.add_poses();
      pose->set_x(v[0]);
      pose->set_y(v[1]);
      pose->set_z(v[2]);
      pose->set_theta(v[3]);
    } else {
      v1::Point3* point = polyline.add_points();
      point->set_x(v[0]);
      point->set_y(v[1]);
      point->set_z(v[2]);
    }
  }
  if (has_waypoints) {
    *request->mutable_waypoints() = std::move(waypoints);
  } else {
    *request->mutable_polyline() = std::move(polyline);
  }
  return absl::OkStatus();
}

// Why a file could not be opened or read ("No such file or directory"), as
// far as errno tells.
std::string ErrnoText() { return errno != 0 ? std::strerror(errno) : "unknown error"; }

// The whole file, refusing one larger than kMaxTrajectoryFileBytes without
// reading past the bound.
absl::StatusOr<std::string> ReadBounded(const std::string& path) {
  const std::string too_large = absl::StrFormat("trajectory file '%s' is larger than %d bytes",
                                                path, kMaxTrajectoryFileBytes);
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    return absl::NotFoundError(
        absl::StrFormat("cannot open trajectory file '%s': %s", path, ErrnoText()));
  }
  std::string text;
  // A regular file's size is known up front: refuse it unread, or read it
  // without regrowing the string. A pipe or a device has no size; the loop
  // below stops it at the bound.
  std::error_code ec;
  if (const uintmax_t size = std::filesystem::file_size(path, ec); !ec) {
    if (size > kMaxTrajectoryFileBytes) return absl::InvalidArgumentError(too_large);
    text.reserve(size);
  }
  char buffer[1 << 16];
  while (in.read(buffer, sizeof buffer) || in.gcount() > 0) {
    text.append(buffer, static_cast<size_t>(in.gcount()));
    if (text.size() > kMaxTrajectoryFileBytes) return absl::InvalidArgumentError(too_large);
  }
  // A directory opens but cannot be read (EISDIR).
  if (in.bad()) {
    return absl::NotFoundError(
        absl::StrFormat("cannot read trajectory file '%s': %s", path, ErrnoText()));
  }
  return text;
}

}  // namespace

absl::Status ParseTrajectoryJson(std::string_view json, v1::EvaluateRiskRequest* request) {
  assert(request != nullptr);
  return ParseJson(json, "trajectory JSON", request);
}

absl::Status ReadTrajectoryFile(const std::string& path, v1::EvaluateRiskRequest* request) {
  assert(request != nullptr);
  absl::StatusOr<std::string> text = ReadBounded(path);
  if (!text.ok()) return text.status();
  return ParseJson(*text, absl::StrFormat("trajectory file '%s'", path), request);
}

// nlohmann writes each double with the fewest digits that read back as the
// same double, so a saved plan's waypoints are read back as the very values
// the server sent, and evaluate to the risk the plan reported.
std::string WaypointsToJson(const google::protobuf::RepeatedPtrField<v1::Pose>& poses) {
  nlohmann::json points = nlohmann::json::array();
  for (const v1::Pose& p : poses) points.push_back({p.x(), p.y(), p.z(), p.theta()});
  nlohmann::json doc = {{"waypoints", points}};
  return doc.dump() + "\n";
}

absl::StatusOr<std::map<std::string, double>> ParseNameValues(std::string_view text) {
  std::map<std::string, double> out;
  for (absl::string_view item :
       absl::StrSplit(absl::string_view(text.data(), text.size()), ',', absl::SkipWhitespace())) {
    std::vector<absl::string_view> kv = absl::StrSplit(item, absl::MaxSplits('=', 1));
    double value = 0.0;
    if (kv.size() != 2 || !absl::SimpleAtod(absl::StripAsciiWhitespace(kv[1]), &value) ||
        !std::isfinite(value)) {
      return absl::InvalidArgumentError(
          absl::StrFormat("'%s' is not name=number", std::string(item)));
    }
    out[std::string(absl::StripAsciiWhitespace(kv[0]))] = value;
  }
  return out;
}

// By reflection rather than by a table of names, so that a parameter added
// to ModelParameters works here without a change; the server checks the
// ranges (docs/risk-model.md).
absl::Status ParseModelParameters(std::string_view text, v1::ModelParameters* params) {
  assert(params != nullptr);
  absl::StatusOr<std::map<std::string, double>> values = ParseNameValues(text);
  if (!values.ok()) return values.status();
  const google::protobuf::Descriptor* descriptor = params->GetDescriptor();
  const google::protobuf::Reflection* reflection = params->GetReflection();
  for (const auto& [name, value] : *values) {
    const google::protobuf::FieldDescriptor* field = descriptor->FindFieldByName(name);
    if (field == nullptr) {
      std::vector<std::string> known;
      for (int i = 0; i < descriptor->field_count(); ++i)
        known.push_back(descriptor->field(i)->name());
      return absl::InvalidArgumentError(absl::StrFormat("unknown model parameter '%s'; known: %s",
                                                        name, absl::StrJoin(known, ", ")));
    }
    // Integer fields (heading_bins) must get a whole number; the bound keeps
    // the cast within int32 (the server checks the real range).
    if (field->cpp_type() == google::protobuf::FieldDescriptor::CPPTYPE_INT32) {
      if (value != std::floor(value) || std::fabs(value) > 2e9) {
        return absl::InvalidArgumentError(absl::StrFormat(
            "model parameter '%s' has value %g; it must be a whole number", name, value));
      }
      reflection->SetInt32(params, field, static_cast<int32_t>(value));
    } else {
      reflection->SetDouble(params, field, value);
    }
  }
  return absl::OkStatus();
}

}  // namespace riskplan::client
