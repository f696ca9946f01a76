// Fuzz target: the trajectory JSON rule of docs/api.md ("Trajectory files"),
// parsed once (formats/trajectory_json.h) and read through two adapters:
// riskplan-tool's reader (core/flight/trajectory_io.h) and the CLI client's
// (client/trajectory_text.h), since the client may not use core.
//
// Input: the JSON text.
//
// Properties: both readers accept exactly the same texts, with the same
// points bit for bit, and refuse the others with the same message; the
// client leaves its request untouched when it refuses.
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

void Run(std::string_view json) {
  const absl::StatusOr<TrajectoryInput> core = ParseTrajectoryJson(json);
  v1::EvaluateRiskRequest request;
  request.set_map("untouched");
  const absl::Status client = client::ParseTrajectoryJson(json, &request);
  if (core.ok() != client.ok()) {
    Fail("riskplan-tool " + core.status().ToString() + ", riskplan " + client.ToString());
  }
  if (!client.ok()) {
    if (core.status() != client) {
      Fail("refused differently: " + core.status().ToString() + " | " + client.ToString());
    }
    if (request.map() != "untouched" || request.has_waypoints() || request.has_polyline()) {
      Fail("a refused text changed the request");
    }
    return;
  }
  if (core->is_polyline()) {
    if (!request.has_polyline() || request.has_waypoints()) Fail("polyline read as waypoints");
    if (static_cast<size_t>(request.polyline().points_size()) != core->polyline.size()) {
      Fail("polyline sizes differ");
    }
    for (size_t k = 0; k < core->polyline.size(); ++k) {
      const Point3& a = core->polyline[k];
      const v1::Point3& b = request.polyline().points(static_cast<int>(k));
      if (!Same(a.x, b.x()) || !Same(a.y, b.y()) || !Same(a.z, b.z())) Fail("polyline points");
    }
  } else {
    if (!request.has_waypoints() || request.has_polyline()) Fail("waypoints read as polyline");
    if (static_cast<size_t>(request.waypoints().poses_size()) != core->waypoints.size()) {
      Fail("waypoint counts differ");
    }
    for (size_t k = 0; k < core->waypoints.size(); ++k) {
      const Pose& a = core->waypoints[k];
      const v1::Pose& b = request.waypoints().poses(static_cast<int>(k));
      if (!Same(a.x, b.x()) || !Same(a.y, b.y()) || !Same(a.z, b.z()) ||
          !Same(a.theta, b.theta())) {
        Fail("waypoints differ");
      }
    }
  }
}

}  // namespace
}  // namespace riskplan::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  riskplan::fuzz::Run(std::string_view(reinterpret_cast<const char*>(data), size));
  return 0;
}
