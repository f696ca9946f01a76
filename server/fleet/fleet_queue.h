// FleetQueue: admission and order of PlanFleet's mission groups.
//
// A PlanFleet call is admitted by its missions: every mission of every
// fleet admitted and not yet ended (queued or planning) counts against
// max_admitted_missions, and a call whose missions do not fit is refused as
// a whole. Its missions are then planned in groups (server/fleet/fleet_request.h:
// RISK_RRT_STAR missions sharing one tree, or one mission alone); a group
// holds one plan slot while it plans, and at most max_running_groups groups
// plan at once.
//
// Which waiting group gets a free slot, in this order:
//   1. fair share: the group of the identity (server/security/auth.h's caller
//      identity, or the request's tenant) that has the fewest groups
//      planning, and among those the one that started a group longest ago
//      (or never): callers take turns, so that one with many groups waiting
//      cannot keep another out of every slot, even of a single slot;
//   2. priority: the highest FleetMission.priority of the group's missions;
//      in effect it orders a caller's own groups (and those of callers
//      served alike), never one caller before another that is owed a turn:
//      a priority is the caller's own word;
//   3. arrival: the group queued first.
// A running group is never preempted.
//
// Pure logic, no locking and no clock: FleetScheduler holds it under its
// mutex. Groups are named by ids the caller chooses, unique while queued or
// running.
#ifndef RISKPLAN_SERVER_FLEET_FLEET_QUEUE_H_
#define RISKPLAN_SERVER_FLEET_FLEET_QUEUE_H_

#include <cstdint>
#include <map>
#include <optional>
#include <string>

#include "absl/container/flat_hash_map.h"

namespace riskplan::server {

class FleetQueue {
 public:
  // REQUIRES: max_running_groups >= 1, max_admitted_missions >= 1.
  FleetQueue(int max_running_groups, int64_t max_admitted_missions)
      : max_running_groups_(max_running_groups), max_admitted_missions_(max_admitted_missions) {}

  // Counts `missions` more as admitted, unless that would pass
  // max_admitted_missions: false then, and nothing changes.
  bool TryAdmit(int64_t missions);
  // Gives back `missions` admitted ones that will never be queued (a
  // mission that failed validation, or a call that ended first).
  void Unadmit(int64_t missions);

  // Queues group `id` of `missions` admitted missions for `identity`.
  // REQUIRES: `id` is neither queued nor running.
  void Push(uint64_t id, const std::string& identity, int priority, int64_t missions);
  // The group that should take the next free slot, if a group slot is
  // free and a group waits. Changes nothing.
  std::optional<uint64_t> Next() const;
  // Moves queued group `id` to running. REQUIRES: it is queued.
  void Start(uint64_t id);
  // A running group ended: frees its slot and its missions. A queued group
  // removed (its call ended before it planned): frees its missions. False
  // when `id` is neither queued nor running.
  bool Finish(uint64_t id);
  // Whether `id` is queued (not yet running).
  bool IsQueued(uint64_t id) const;

  int running_groups() const { return running_groups_; }
  int64_t admitted_missions() const { return admitted_missions_; }
  int64_t queued_missions() const { return queued_missions_; }
  int64_t running_missions() const { return running_missions_; }
  int64_t max_admitted_missions() const { return max_admitted_missions_; }
  // Groups of `identity` planning now.
  int RunningOf(const std::string& identity) const;

 private:
  struct Group {
    std::string identity;
    int priority = 0;
    int64_t missions = 0;
    bool running = false;
  };

  const int max_running_groups_;
  const int64_t max_admitted_missions_;
  // Queued and running groups, by id; ids grow with arrival in practice, but
  // the order of arrival is kept separately so that any ids work.
  std::map<uint64_t, Group> groups_;
  std::map<uint64_t, uint64_t> arrival_;  // arrival number -> queued id
  uint64_t arrivals_ = 0;
  absl::flat_hash_map<std::string, int> running_by_identity_;
  // Per identity with a group queued or running: its groups, and when it
  // last started one (a count of starts; 0: never). Forgotten once it has
  // no group, so that the maps hold only the identities being served.
  absl::flat_hash_map<std::string, int> groups_by_identity_;
  absl::flat_hash_map<std::string, uint64_t> last_start_;
  uint64_t starts_ = 0;
  int running_groups_ = 0;
  int64_t admitted_missions_ = 0;
  int64_t queued_missions_ = 0;
  int64_t running_missions_ = 0;
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_FLEET_FLEET_QUEUE_H_
