// The trajectory JSON rule of docs/api.md ("Trajectory files"), parsed in one
// place for riskplan-tool (core/flight/trajectory_io.h) and the CLI client
// (client/trajectory_text.h):
//
//   {"waypoints": [[x, y, z, theta], ...]}   or   {"polyline": [[x, y, z], ...]}
//
// Each of the two turns the points read here into its own types (core's
// geometry, the API's messages); this leaf knows neither, so that core and
// the client still link nothing of each other.
// tests/data/trajectory_json_cases.json is the table of cases both adapters
// are tested against.
#ifndef RISKPLAN_FORMATS_TRAJECTORY_JSON_H_
#define RISKPLAN_FORMATS_TRAJECTORY_JSON_H_

#include <array>
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"

namespace riskplan::formats {

// Most points a trajectory JSON may hold: the default `max_points` of
// PiecesFromWaypoints and PiecesFromPolyline (core/flight/trajectory.h). The
// server by default accepts fewer (--max_waypoints), but one file is accepted
// or refused alike by riskplan-tool and the CLI.
inline constexpr size_t kMaxTrajectoryJsonPoints = 100000;
// Largest trajectory file read (the same bound as a map bundle's manifest).
inline constexpr size_t kMaxTrajectoryFileBytes = size_t{64} << 20;

// The points of a trajectory file, as given: for waypoints each point is
// {x, y, z, theta} (theta not normalised), for a polyline {x, y, z, 0}. One
// array type for both keeps the parser a single loop; every number is finite
// (JSON has no NaN or infinity, and a number out of a double's range is a
// syntax error).
struct TrajectoryJson {
  bool is_polyline = false;
  std::vector<std::array<double, 4>> points;  // 2 to kMaxTrajectoryJsonPoints
};

// Trajectory JSON text. Errors are InvalidArgument: the prefix
// "trajectory JSON: ", then the JSON path at fault and what is wrong, e.g.
// `waypoints[3].theta must be a number, got string "1.57"`.
absl::StatusOr<TrajectoryJson> ParseTrajectoryJson(std::string_view json);
// The same from a file of at most kMaxTrajectoryFileBytes; errors in its
// content start with "trajectory file 'PATH': " instead. A file that cannot
// be opened or read is NotFound ("cannot open trajectory file 'PATH': ..."),
// anything else InvalidArgument.
absl::StatusOr<TrajectoryJson> ReadTrajectoryFile(const std::string& path);

}  // namespace riskplan::formats

#endif  // RISKPLAN_FORMATS_TRAJECTORY_JSON_H_
