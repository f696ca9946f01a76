#include "server/fleet/fleet_request.h"

#include <algorithm>
#include <map>
#include <utility>

#include "absl/container/flat_hash_set.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/planners/shared_goal_tree.h"
#include "server/models/model_cache.h"

namespace riskplan::server {
namespace {

// Equal exactly when two missions may share one tree: every input of the
// tree but the starts and budgets, doubles by their exact hex form.
std::string TreeKey(const PlanSpec& plan) {
  std::string key = absl::StrFormat("%s|%a,%a,%a,%a|%d|%d|", plan.map->name(), plan.goal.x,
                                    plan.goal.y, plan.goal.z, plan.goal.theta, plan.options.seed,
                                    plan.options.max_edge_samples);
  absl::StrAppend(&key, RiskModelCache::Fingerprint(plan.params), "|");
  for (const auto& [name, value] : plan.options.params) {
    absl::StrAppendFormat(&key, "%s=%a,", name, value);
  }
  return key;
}

}  // namespace

absl::Status MissionError(size_t index, const absl::Status& status) {
  if (status.ok()) return status;
  if (absl::IsInvalidArgument(status) || absl::IsNotFound(status)) {
    return absl::Status(status.code(),
                        absl::StrFormat("missions[%d].request.%s", index, status.message()));
  }
  return absl::Status(status.code(), absl::StrFormat("missions[%d]: %s", index, status.message()));
}

absl::StatusOr<FleetSpec> ValidateFleetRequest(const v1::FleetRequest& request,
                                               const MapRegistry& registry,
                                               const RequestLimits& limits) {
  // Counted before anything is read or allocated for the missions.
  const size_t count = static_cast<size_t>(request.missions_size());
  if (count == 0 || count > limits.max_fleet_missions) {
    return absl::InvalidArgumentError(
        absl::StrFormat("missions has %d missions; it must have 1 to %d (--max_fleet_missions)",
                        count, limits.max_fleet_missions));
  }
  if (request.tenant().size() > kMaxTenantBytes) {
    return absl::InvalidArgumentError(absl::StrFormat("tenant has %d bytes; at most %d",
                                                      request.tenant().size(), kMaxTenantBytes));
  }
  absl::flat_hash_set<std::string> ids;
  ids.reserve(count);
  for (int i = 0; i < request.missions_size(); ++i) {
    const v1::FleetMission& m = request.missions(i);
    if (m.id().empty() || m.id().size() > kMaxMissionIdBytes) {
      return absl::InvalidArgumentError(
          absl::StrFormat("missions[%d].id has %d bytes; it must have 1 to %d", i, m.id().size(),
                          kMaxMissionIdBytes));
    }
    if (!ids.insert(m.id()).second) {
      return absl::InvalidArgumentError(
          absl::StrFormat("missions[%d].id '%s' is the id of an earlier mission; ids must be "
                          "unique",
                          i, m.id()));
    }
    if (m.priority() < 0 || m.priority() > kMaxMissionPriority) {
      return absl::InvalidArgumentError(
          absl::StrFormat("missions[%d].priority has value %d; it must be in [0, %d]", i,
                          m.priority(), kMaxMissionPriority));
    }
  }
  FleetSpec spec;
  spec.send_improvements = request.send_improvements();
  spec.tenant = request.tenant();
  spec.missions.reserve(count);
  for (int i = 0; i < request.missions_size(); ++i) {
    const v1::FleetMission& m = request.missions(i);
    absl::StatusOr<PlanSpec> plan = ValidatePlanRequest(m.request(), registry, limits);
    if (!plan.ok()) plan = MissionError(i, plan.status());
    spec.missions.push_back({.id = m.id(), .priority = m.priority(), .plan = std::move(plan)});
  }
  return spec;
}

std::vector<MissionGroup> GroupMissions(const FleetSpec& spec) {
  std::vector<MissionGroup> groups;
  std::map<std::string, size_t> open;  // tree key -> its group that still has room
  for (size_t i = 0; i < spec.missions.size(); ++i) {
    const FleetMissionSpec& m = spec.missions[i];
    if (!m.plan.ok()) continue;
    size_t g = groups.size();
    // A mission with limits (endurance, target level of safety, objective,
    // front) is planned alone: MakePlanner's planner applies its own limits.
    if (m.plan->algorithm == PlannerAlgorithm::kRiskRrtStar && !m.plan->options.limits.Active()) {
      const std::string key = TreeKey(*m.plan);
      auto it = open.find(key);
      if (it != open.end() && groups[it->second].missions.size() < kMaxSharedTreeMissions) {
        g = it->second;
      } else {
        open[key] = g;
      }
    }
    if (g == groups.size())
      groups.push_back(MissionGroup{.missions = {}, .shared = false, .priority = m.priority});
    MissionGroup& group = groups[g];
    group.missions.push_back(i);
    group.priority = std::max(group.priority, m.priority);
  }
  for (MissionGroup& group : groups) group.shared = group.missions.size() > 1;
  return groups;
}

}  // namespace riskplan::server
