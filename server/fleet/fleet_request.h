// PlanFleet's request at the RPC edge: validation of the whole fleet and of
// each mission, and the groups its missions are planned in.
//
// Refused as a whole (INVALID_ARGUMENT, before anything is allocated for the
// missions): no missions, more than --max_fleet_missions, a mission id that
// is empty, longer than 128 bytes or repeated, a priority outside
// [0, 1000], a tenant longer than 64 bytes. Everything else a mission's
// PlanRequest can get wrong is that mission's own error (ValidatePlanRequest,
// its message prefixed "missions[i].request."), and the others go on.
#ifndef RISKPLAN_SERVER_FLEET_FLEET_REQUEST_H_
#define RISKPLAN_SERVER_FLEET_FLEET_REQUEST_H_

#include <cstddef>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "riskplan/v1/planner.pb.h"
#include "server/models/map_registry.h"
#include "server/api/request_validation.h"

namespace riskplan::server {

inline constexpr size_t kMaxMissionIdBytes = 128;
inline constexpr size_t kMaxTenantBytes = 64;
inline constexpr int kMaxMissionPriority = 1000;

struct FleetMissionSpec {
  std::string id;
  int priority = 0;
  absl::StatusOr<PlanSpec> plan;  // the mission's own error when it is not valid
};

struct FleetSpec {
  std::vector<FleetMissionSpec> missions;  // in request order
  bool send_improvements = false;
  std::string tenant;
};

absl::StatusOr<FleetSpec> ValidateFleetRequest(const v1::FleetRequest& request,
                                               const MapRegistry& registry,
                                               const RequestLimits& limits);

// Missions planned together. `shared`: RISK_RRT_STAR missions with the same
// map, goal (bit for bit), model parameters, planner parameters and seed,
// at least two of them, grown on one tree (SharedGoalTreePlanner); else one
// mission planned alone.
struct MissionGroup {
  std::vector<size_t> missions;  // indices into FleetSpec::missions, ascending
  bool shared = false;
  int priority = 0;  // the highest of its missions'
};

// The groups of the valid missions of `spec`, in order of their first
// mission; a shared group holds at most kMaxSharedTreeMissions missions (more
// make further groups). Deterministic: the same request, the same groups.
std::vector<MissionGroup> GroupMissions(const FleetSpec& spec);

// `status` as the error of mission `index`: "missions[i].request." before a
// message that names a field of its PlanRequest (INVALID_ARGUMENT,
// NOT_FOUND), "missions[i]: " before any other.
absl::Status MissionError(size_t index, const absl::Status& status);

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_FLEET_FLEET_REQUEST_H_
