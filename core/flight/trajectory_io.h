// Text forms of trajectories, shared by the command-line tools.
//
//   waypoints: "x,y,z,theta; x,y,z,theta; ..."   (m, m, m AMSL, rad)
//   polyline:  "x,y,z; x,y,z; ..."
//   file:      JSON {"waypoints": [[x, y, z, theta], ...]} or
//              JSON {"polyline": [[x, y, z], ...]}
#ifndef RISKPLAN_CORE_FLIGHT_TRAJECTORY_IO_H_
#define RISKPLAN_CORE_FLIGHT_TRAJECTORY_IO_H_

#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"

namespace riskplan {

struct TrajectoryInput {
  std::vector<Pose> waypoints;   // set for waypoint input
  std::vector<Point3> polyline;  // set for polyline input
  bool is_polyline() const { return !polyline.empty(); }
};

// Errors name the point index and the text at fault.
absl::StatusOr<std::vector<Pose>> ParseWaypoints(std::string_view text);
absl::StatusOr<std::vector<Point3>> ParsePolyline(std::string_view text);
absl::StatusOr<TrajectoryInput> ParseTrajectoryJson(std::string_view json);
absl::StatusOr<TrajectoryInput> ReadTrajectoryFile(const std::string& path);

}  // namespace riskplan

#endif  // RISKPLAN_CORE_FLIGHT_TRAJECTORY_IO_H_
