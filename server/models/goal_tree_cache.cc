#include "server/models/goal_tree_cache.h"

#include <utility>
#include <vector>

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
  const std::string encoded = key.Encode();
  absl::MutexLock lock(&mu_);
  auto it = entries_.find(encoded);
  if (it == entries_.end()) {
    ++stats_.misses;
    return nullptr;
  }
  ++stats_.hits;
  lru_.splice(lru_.begin(), lru_, it->second.lru);
  return it->second.tree;
}

void GoalTreeCache::Put(const GoalTreeKey& key, std::shared_ptr<const GoalTree> tree) {
  if (tree == nullptr || tree->nodes.empty()) return;
  std::string encoded = key.Encode();
  const size_t bytes = TreeBytes(*tree, encoded.size());
  // Trees replaced or evicted are freed outside the lock (`dropped` outlives
  // it): freeing a large tree's nodes need not hold up other requests.
  std::vector<std::shared_ptr<const GoalTree>> dropped;
  absl::MutexLock lock(&mu_);
  if (bytes > max_bytes_) return;
  auto it = entries_.find(encoded);
  if (it != entries_.end()) {
    if (it->second.tree->nodes.size() >= tree->nodes.size()) return;
    stats_.bytes -= it->second.bytes;
    dropped.push_back(std::exchange(it->second.tree, std::move(tree)));
    it->second.bytes = bytes;
    lru_.splice(lru_.begin(), lru_, it->second.lru);
  } else {
    lru_.push_front(encoded);
    entries_.emplace(std::move(encoded), Entry{std::move(tree), bytes, lru_.begin()});
  }
  stats_.bytes += bytes;
  EvictLocked(&dropped);
}

void GoalTreeCache::EvictLocked(std::vector<std::shared_ptr<const GoalTree>>* dropped) {
  // The newest entry fits on its own (Put checked), so this stops before it.
  while (stats_.bytes > max_bytes_ && !lru_.empty()) {
    auto it = entries_.find(lru_.back());
    stats_.bytes -= it->second.bytes;
    dropped->push_back(std::move(it->second.tree));
    entries_.erase(it);
    lru_.pop_back();
    ++stats_.evictions;
  }
}

GoalTreeCache::Stats GoalTreeCache::stats() const {
  absl::MutexLock lock(&mu_);
  Stats s = stats_;
  s.entries = entries_.size();
  return s;
}

}  // namespace riskplan::server
