#include "client/trajectory_text.h"

#include <cmath>
#include <fstream>
#include <sstream>
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

// Splits "a,b,c" into exactly `count` finite numbers.
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

std::vector<std::string> Points(std::string_view text) {
  std::vector<std::string> points;
  for (absl::string_view part :
       absl::StrSplit(absl::string_view(text.data(), text.size()), ';', absl::SkipWhitespace())) {
    points.emplace_back(absl::StripAsciiWhitespace(part));
  }
  return points;
}

}  // namespace

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

absl::Status ParseTrajectoryJson(std::string_view json, v1::EvaluateRiskRequest* request) {
  nlohmann::json doc = nlohmann::json::parse(json, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded() || !doc.is_object()) {
    return absl::InvalidArgumentError("trajectory file: not a JSON object");
  }
  const bool has_waypoints = doc.contains("waypoints");
  const bool has_polyline = doc.contains("polyline");
  if (has_waypoints == has_polyline) {
    return absl::InvalidArgumentError(
        "trajectory file: needs exactly one of \"waypoints\" and \"polyline\"");
  }
  const char* key = has_waypoints ? "waypoints" : "polyline";
  const size_t width = has_waypoints ? 4 : 3;
  const nlohmann::json& points = doc[key];
  if (!points.is_array() || points.size() < 2) {
    return absl::InvalidArgumentError(
        absl::StrFormat("trajectory file: \"%s\" must be an array of at least 2 points", key));
  }
  request->clear_trajectory();
  for (size_t i = 0; i < points.size(); ++i) {
    const nlohmann::json& p = points[i];
    std::vector<double> v;
    if (p.is_array() && p.size() == width) {
      for (const nlohmann::json& n : p) {
        if (!n.is_number() || !std::isfinite(n.get<double>())) break;
        v.push_back(n.get<double>());
      }
    }
    if (v.size() != width) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "trajectory file: %s[%d] is %s; expected %d finite numbers", key, i, p.dump(), width));
    }
    if (has_waypoints) {
      v1::Pose* pose = request->mutable_waypoints()->add_poses();
      pose->set_x(v[0]);
      pose->set_y(v[1]);
      pose->set_z(v[2]);
      pose->set_theta(v[3]);
    } else {
      v1::Point3* point = request->mutable_polyline()->add_points();
      point->set_x(v[0]);
      point->set_y(v[1]);
      point->set_z(v[2]);
    }
  }
  return absl::OkStatus();
}

absl::Status ReadTrajectoryFile(const std::string& path, v1::EvaluateRiskRequest* request) {
  std::ifstream in(path);
  if (!in) return absl::NotFoundError(absl::StrFormat("cannot read trajectory file '%s'", path));
  std::stringstream text;
  text << in.rdbuf();
  absl::Status status = ParseTrajectoryJson(text.str(), request);
  if (!status.ok()) {
    return absl::Status(status.code(), absl::StrFormat("%s (%s)", status.message(), path));
  }
  return status;
}

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

absl::Status ParseModelParameters(std::string_view text, v1::ModelParameters* params) {
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
