#include "client/trajectory_text.h"

#include <cassert>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "formats/trajectory_json.h"
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

// The API's messages for the points of the shared rule
// (formats/trajectory_json.h). `request` is set only once the whole text has
// passed, so a refused file leaves it as it was.
absl::Status SetTrajectory(absl::StatusOr<formats::TrajectoryJson> json,
                           v1::EvaluateRiskRequest* request) {
  if (!json.ok()) return json.status();
  if (json->is_polyline) {
    v1::Polyline polyline;
    for (const auto& v : json->points) {
      v1::Point3* point = polyline.add_points();
      point->set_x(v[0]);
      point->set_y(v[1]);
      point->set_z(v[2]);
    }
    *request->mutable_polyline() = std::move(polyline);
  } else {
    v1::Waypoints waypoints;
    for (const auto& v : json->points) {
      v1::Pose* pose = waypoints.add_poses();
      pose->set_x(v[0]);
      pose->set_y(v[1]);
      pose->set_z(v[2]);
      pose->set_theta(v[3]);
    }
    *request->mutable_waypoints() = std::move(waypoints);
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status ParseTrajectoryJson(std::string_view json, v1::EvaluateRiskRequest* request) {
  assert(request != nullptr);
  return SetTrajectory(formats::ParseTrajectoryJson(json), request);
}

absl::Status ReadTrajectoryFile(const std::string& path, v1::EvaluateRiskRequest* request) {
  assert(request != nullptr);
  return SetTrajectory(formats::ReadTrajectoryFile(path), request);
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
absl::Status ParseWind(std::string_view text, std::string_view flag, v1::Wind* wind,
                       v1::GeoWind* wind_wgs84, bool* is_wgs84) {
  assert(wind != nullptr && wind_wgs84 != nullptr && is_wgs84 != nullptr);
  std::string_view rest;
  const bool geo = HasWgs84Prefix(text, &rest);
  auto bad = [&](std::string_view why) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s='%s' is not %sSPEED@FROM_DEG (m/s @ degrees clockwise from %s north the wind "
        "blows from, e.g. %s8@270 for a west wind of 8 m/s): %s",
        flag, text, geo ? "wgs84:" : "", geo ? "true" : "the map's grid", geo ? "wgs84:" : "",
        why));
  };
  const std::vector<std::string> parts =
      absl::StrSplit(absl::string_view(rest.data(), rest.size()), '@');
  if (parts.size() != 2) return bad("it needs one '@' between the speed and the direction");
  double speed = 0.0;
  double from = 0.0;
  if (!absl::SimpleAtod(absl::StripAsciiWhitespace(parts[0]), &speed) || !std::isfinite(speed)) {
    return bad(absl::StrFormat("the speed '%s' is not a finite number", parts[0]));
  }
  if (speed < 0.0) return bad(absl::StrFormat("the speed %g is negative", speed));
  if (!absl::SimpleAtod(absl::StripAsciiWhitespace(parts[1]), &from) || !std::isfinite(from)) {
    return bad(absl::StrFormat("the direction '%s' is not a finite number", parts[1]));
  }
  v1::WindFrom w;
  w.set_speed_mps(speed);
  w.set_from_deg(from);
  *is_wgs84 = geo;
  if (geo) {
    *wind_wgs84->mutable_from() = w;
  } else {
    *wind->mutable_from() = w;
  }
  return absl::OkStatus();
}

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
