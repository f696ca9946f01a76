// GoalTreeCache: the RISK_RRT_STAR goal trees that PlanFleet's shared groups
// grew (core/planners/shared_goal_tree.h, GoalTree), kept across requests so
// that a later fleet to the same goal begins from the grown tree instead of
// the goal alone.
//
// Derived data only: a tree holds nothing a client sent but what its key
// holds, and losing it (eviction, a restart, another replica) costs only
// planning time, so the server stays stateless for clients. A hit may give a
// different (usually better) trajectory than a miss for the same request:
// docs/planners.md, "Goal tree cache".
//
// A tree is valid only for the exact model and planner it was grown with;
// the key holds every input that shapes it: the map's name and identity, the
// goal pose, every model parameter and planner parameter (bit for bit), and
// the seed.
//
// Bounded by an estimate of bytes (TreeBytes), least recently used first out
// (a BoundedCache keyed by GoalTreeKey::Encode(), core/base/bounded_cache.h).
// Trees are immutable and shared (shared_ptr<const GoalTree>): a request that
// hits reads one while another request inserts or evicts, and the planner
// copies it before growing its own (SharedTreeOptions::initial_tree).
//
// Thread-safe.
#ifndef RISKPLAN_SERVER_MODELS_GOAL_TREE_CACHE_H_
#define RISKPLAN_SERVER_MODELS_GOAL_TREE_CACHE_H_

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <string>

#include "core/base/bounded_cache.h"
#include "core/base/geometry.h"
#include "core/base/model_params.h"
#include "core/planners/shared_goal_tree.h"

namespace riskplan::server {

// What a goal tree was grown for.
struct GoalTreeKey {
  std::string map_name;
  // Tells apart two maps of one name: the registry loads each map once and
  // never replaces it, so its address is its version while the server runs.
  uintptr_t map_identity = 0;
  Pose goal;
  ModelParams model_params;
  std::map<std::string, double> planner_params;  // as the request gave them
  uint64_t seed = 1;

  // A string equal exactly when every field is equal, doubles bit for bit.
  std::string Encode() const;
};

class GoalTreeCache {
 public:
  // REQUIRES: max_bytes > 0 (a server without the cache has none).
  explicit GoalTreeCache(size_t max_bytes) : cache_({.max_bytes = max_bytes}) {}

  // The tree for `key`, made the most recently used, or null (a miss).
  // Counts a hit or a miss.
  std::shared_ptr<const GoalTree> Find(const GoalTreeKey& key);

  // Keeps `tree` for `key` unless the cache already holds a tree with at
  // least as many nodes for it (two fleets that grew one tree at once: the
  // larger stays), then evicts least recently used trees until the total is
  // within max_bytes. A tree larger than max_bytes on its own is not kept.
  void Put(const GoalTreeKey& key, std::shared_ptr<const GoalTree> tree);

  // The estimate the bound counts: the nodes (sizeof(GoalTreeNode) each:
  // pose, parent, cost, edge risk; a GoalTree keeps no children lists), the
  // parameter map's entries, the key's string and a fixed overhead per
  // entry for the GoalTree, the map node, the LRU node and shared_ptr's
  // control block. Not counted: a copy a running plan makes (its Run's
  // nodes with children lists, a few times as large), which lives only as
  // long as the plan.
  static size_t TreeBytes(const GoalTree& tree, size_t key_bytes);

  // Hits and misses of Find(), trees evicted to stay within the bound, and
  // the trees cached with their TreeBytes.
  using Stats = CacheStats;
  Stats stats() const { return cache_.stats(); }
  size_t max_bytes() const { return cache_.limits().max_bytes; }

 private:
  // Trees replaced or evicted are freed outside its lock: freeing a large
  // tree's nodes need not hold up other requests.
  BoundedCache<std::string, GoalTree> cache_;
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_MODELS_GOAL_TREE_CACHE_H_
