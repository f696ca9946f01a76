// Text forms of trajectories, shared by the command-line tools.
//
//   waypoints: "x,y,z,theta; x,y,z,theta; ..."   (m, m, m AMSL, rad)
//   polyline:  "x,y,z; x,y,z; ..."
//   file:      JSON {"waypoints": [[x, y, z, theta], ...]} or
//              JSON {"polyline": [[x, y, z], ...]}
//
// The JSON rule is documented in docs/api.md ("Trajectory files") and parsed
// by formats/trajectory_json.h, which the CLI client uses too
// (client/trajectory_text.h: the client may not depend on core);
// tests/data/trajectory_json_cases.json is the one table of cases both are
// tested against.
#ifndef RISKPLAN_CORE_FLIGHT_TRAJECTORY_IO_H_
#define RISKPLAN_CORE_FLIGHT_TRAJECTORY_IO_H_

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "formats/trajectory_json.h"

namespace riskplan {

// Most points a trajectory JSON may hold: the default `max_points` of
// PiecesFromWaypoints and PiecesFromPolyline (core/flight/trajectory.h).
inline constexpr size_t kMaxTrajectoryJsonPoints = formats::kMaxTrajectoryJsonPoints;
// Largest trajectory file read (the same bound as a map bundle's manifest).
inline constexpr size_t kMaxTrajectoryFileBytes = formats::kMaxTrajectoryFileBytes;

struct TrajectoryInput {
  std::vector<Pose> waypoints;   // set for waypoint input
  std::vector<Point3> polyline;  // set for polyline input
  bool is_polyline() const { return !polyline.empty(); }
};

// Errors name the point index and the text at fault.
absl::StatusOr<std::vector<Pose>> ParseWaypoints(std::string_view text);
absl::StatusOr<std::vector<Point3>> ParsePolyline(std::string_view text);

// Trajectory JSON text. Errors are InvalidArgument: the prefix
// "trajectory JSON: ", then the JSON path at fault and what is wrong, e.g.
// `waypoints[3].theta must be a number, got string "1.57"`. Headings are
// returned as given (not normalised).
absl::StatusOr<TrajectoryInput> ParseTrajectoryJson(std::string_view json);
// The same from a file of at most kMaxTrajectoryFileBytes; errors in its
// content start with "trajectory file 'PATH': " instead. A file that cannot
// be opened or read is NotFound ("cannot open trajectory file 'PATH': ..."),
// anything else InvalidArgument.
absl::StatusOr<TrajectoryInput> ReadTrajectoryFile(const std::string& path);

}  // namespace riskplan

#endif  // RISKPLAN_CORE_FLIGHT_TRAJECTORY_IO_H_
