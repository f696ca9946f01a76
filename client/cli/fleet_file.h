// The missions file of `riskplan fleet --missions=FILE.json` (docs/api.md,
// "Missions files"):
//
//   {"tenant": "ground-1", "send_improvements": true,
//    "missions": [{"id": "north", "start": "300,375,240,0.785", "priority": 5},
//                 {"id": "east", "start": [1600, 400, 250, 1.57], "algorithm": "RRT"}]}
//
// Each mission is built as `riskplan plan` builds its request from its
// flags, with the mission's own fields in place of the flags of the same
// names (start, goal, map, algorithm, budget_ms, iterations, seed, params,
// planner_params, obstacles, min_update_interval_ms, display_step_m, tree),
// so that what every mission shares (a goal, a budget) can be given once as
// flags. Poses are the flags' text or an array of four numbers.
#ifndef RISKPLAN_CLIENT_CLI_FLEET_FILE_H_
#define RISKPLAN_CLIENT_CLI_FLEET_FILE_H_

#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "client/cli/command_options.h"
#include "riskplan/v1/planner.pb.h"

namespace riskplan::client {

// Largest missions file read (a fleet of a few thousand missions fits).
inline constexpr size_t kMaxMissionsFileBytes = 16 << 20;

// The fleet of `json`, each mission built on `base`. INVALID_ARGUMENT naming
// `context` (the file) and where: the line and column of a syntax error, or
// the JSON path of a value ("missions[2].budget_ms: must be an integer"), and
// for an unknown key its name (a typo must not be dropped silently).
absl::StatusOr<v1::FleetRequest> ParseMissionsJson(std::string_view json,
                                                   const std::string& context,
                                                   const CliOptions& base);

// ParseMissionsJson of the file at `path`, read up to kMaxMissionsFileBytes
// (NOT_FOUND when it cannot be read).
absl::StatusOr<v1::FleetRequest> ReadMissionsFile(const std::string& path, const CliOptions& base);

}  // namespace riskplan::client

#endif  // RISKPLAN_CLIENT_CLI_FLEET_FILE_H_
