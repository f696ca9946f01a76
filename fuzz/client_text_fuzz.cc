// Fuzz target: the text forms the CLI client parses from its flags
// (client/trajectory_text.h: --start/--goal poses, --waypoints, --polyline,
// --obstacles, --params and --planner_params name=value lists), and
// riskplan-tool's waypoint and polyline forms (core/flight/trajectory_io.h).
//
// Input: one byte choosing the parser, then the text.
//
// Properties: what the client accepts as waypoints or a polyline,
// riskplan-tool accepts too, with the same numbers bit for bit (the client
// also refuses non-finite numbers and fewer than two points); waypoints the
// client accepted and writes with WaypointsToJson (riskplan plan
// --trajectory_out) read back as the same poses; every refusal says why.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>

#include "client/trajectory_text.h"
#include "core/flight/trajectory_io.h"
#include "fuzz/fuzz_support.h"
#include "riskplan/v1/planner.pb.h"

namespace riskplan::fuzz {
namespace {

bool Same(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

void CheckRefusal(const absl::Status& status) {
  if (!status.ok() && (!absl::IsInvalidArgument(status) || status.message().empty())) {
    Fail(status.ToString());
  }
}

void Waypoints(std::string_view text) {
  absl::StatusOr<v1::Waypoints> client = client::ParseWaypoints(text);
  CheckRefusal(client.status());
  if (!client.ok()) return;
  absl::StatusOr<std::vector<Pose>> tool = ParseWaypoints(text);
  if (!tool.ok()) Fail("riskplan-tool refuses waypoints the client takes: " + tool.status().ToString());
  if (tool->size() != static_cast<size_t>(client->poses_size())) Fail("waypoint counts differ");
  for (int k = 0; k < client->poses_size(); ++k) {
    const v1::Pose& a = client->poses(k);
    const Pose& b = (*tool)[k];
    if (!std::isfinite(a.x()) || !std::isfinite(a.y()) || !std::isfinite(a.z()) ||
        !std::isfinite(a.theta())) {
      Fail("the client took a non-finite waypoint");
    }
    if (!Same(a.x(), b.x) || !Same(a.y(), b.y) || !Same(a.z(), b.z) || !Same(a.theta(), b.theta)) {
      Fail("waypoints differ");
    }
  }
  v1::EvaluateRiskRequest request;
  const absl::Status back =
      client::ParseTrajectoryJson(client::WaypointsToJson(client->poses()), &request);
  if (!back.ok()) Fail("written waypoints do not read back: " + back.ToString());
  if (request.waypoints().poses_size() != client->poses_size()) Fail("read back a different count");
  for (int k = 0; k < client->poses_size(); ++k) {
    const v1::Pose& a = client->poses(k);
    const v1::Pose& b = request.waypoints().poses(k);
    if (!Same(a.x(), b.x()) || !Same(a.y(), b.y()) || !Same(a.z(), b.z()) ||
        !Same(a.theta(), b.theta())) {
      Fail("written waypoints read back different");
    }
  }
}

void Polyline(std::string_view text) {
  absl::StatusOr<v1::Polyline> client = client::ParsePolyline(text);
  CheckRefusal(client.status());
  if (!client.ok()) return;
  absl::StatusOr<std::vector<Point3>> tool = ParsePolyline(text);
  if (!tool.ok()) Fail("riskplan-tool refuses a polyline the client takes: " + tool.status().ToString());
  if (tool->size() != static_cast<size_t>(client->points_size())) Fail("polyline sizes differ");
  for (int k = 0; k < client->points_size(); ++k) {
    const v1::Point3& a = client->points(k);
    const Point3& b = (*tool)[k];
    if (!Same(a.x(), b.x) || !Same(a.y(), b.y) || !Same(a.z(), b.z)) Fail("points differ");
  }
}

void Run(uint8_t which, std::string_view text) {
  switch (which % 6) {
    case 0: {
      absl::StatusOr<v1::Pose> pose = client::ParsePose(text);
      CheckRefusal(pose.status());
      break;
    }
    case 1:
      Waypoints(text);
      break;
    case 2:
      Polyline(text);
      break;
    case 3: {
      absl::StatusOr<std::vector<v1::Point2>> points = client::ParsePoints2(text);
      CheckRefusal(points.status());
      break;
    }
    case 4: {
      absl::StatusOr<std::map<std::string, double>> values = client::ParseNameValues(text);
      CheckRefusal(values.status());
      if (values.ok()) {
        for (const auto& [name, value] : *values) {
          if (!std::isfinite(value)) Fail("a non-finite name=value");
        }
      }
      break;
    }
    default: {
      v1::ModelParameters params;
      CheckRefusal(client::ParseModelParameters(text, &params));
      break;
    }
  }
  // riskplan-tool's forms on their own, whatever the client thinks.
  if (which % 6 == 0) {
    ParseWaypoints(text).IgnoreError();
    ParsePolyline(text).IgnoreError();
  }
}

}  // namespace
}  // namespace riskplan::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  riskplan::fuzz::Run(data[0],
                      std::string_view(reinterpret_cast<const char*>(data + 1), size - 1));
  return 0;
}
