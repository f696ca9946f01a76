#include "server/models/goal_tree_cache.h"

#include <utility>

#include "absl/strings/str_format.h"
#include "server/models/model_cache.h"

namespace riskplan::server {

std::string GoalTreeKey::Encode() const {
  // %a is exact: equal strings mean bit-equal doubles. The map's name goes
  // last but one, length-prefixed, so no name can imitate another field.
  std::string key =
      absl::StrFormat("%x|%a,%a,%a,%a|%d|", map_identity, goal.x, goal.y, goal.z, goal.theta, seed);
  key += RiskModelCache::Fingerprint(model_params);
  for (const auto& [name, value] : planner_params) {
    absl::StrAppendFormat(&key, "|%d:%s=%a", name.size(), name, value);
  }
  absl::StrAppendFormat(&key, "|%d:%s", map_name.size(), map_name);
  return key;
}

size_t GoalTreeCache::TreeBytes(const GoalTree& tree, size_t key_bytes) {
  // A std::map node holds its value, two pointers, a parent and a colour;
  // the fixed part is sizeof(GoalTree) + map and list nodes + the control
  // block, rounded up.
  constexpr size_t kMapNodeBytes = 48;
  constexpr size_t kEntryOverhead = 256;
  size_t params = 0;
  for (const auto& [name, value] : tree.params) params += kMapNodeBytes + name.capacity() + 8;
  return tree.nodes.capacity() * sizeof(GoalTreeNode) + params + 2 * key_bytes + kEntryOverhead +
         sizeof(GoalTree);
}

std::shared_ptr<const GoalTree> GoalTreeCache::Find(const GoalTreeKey& key) {
  return cache_.Find(key.Encode());
}

void GoalTreeCache::Put(const GoalTreeKey& key, std::shared_ptr<const GoalTree> tree) {
  if (tree == nullptr || tree->nodes.empty()) return;
  std::string encoded = key.Encode();
  const size_t bytes = TreeBytes(*tree, encoded.size());
  const size_t nodes = tree->nodes.size();
  cache_.Put(encoded, std::move(tree), bytes,
             [nodes](const GoalTree& cached) { return cached.nodes.size() >= nodes; });
}

}  // namespace riskplan::server
