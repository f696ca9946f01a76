// PlanFleet's admission and queue order (server/fleet/fleet_queue.h): missions
// counted on admission, fair share between identities (fewest planning,
// then turns), then priority, then arrival.
#include "server/fleet/fleet_queue.h"

#include <vector>

#include "gtest/gtest.h"

namespace riskplan::server {
namespace {

// Starts every group Next() offers until no slot is free; their ids in order.
std::vector<uint64_t> StartAll(FleetQueue& q) {
  std::vector<uint64_t> started;
  while (std::optional<uint64_t> next = q.Next()) {
    q.Start(*next);
    started.push_back(*next);
  }
  return started;
}

TEST(FleetQueueTest, AdmissionCountsMissionsNotCalls) {
  FleetQueue q(/*max_running_groups=*/2, /*max_admitted_missions=*/10);
  EXPECT_TRUE(q.TryAdmit(6));
  EXPECT_FALSE(q.TryAdmit(5));  // 11 > 10: refused whole, nothing counted
  EXPECT_EQ(q.admitted_missions(), 6);
  EXPECT_TRUE(q.TryAdmit(4));
  EXPECT_FALSE(q.TryAdmit(1));
  q.Unadmit(4);  // a call that ended before queueing gives them back
  q.Push(1, "a", 0, 6);
  EXPECT_EQ(q.queued_missions(), 6);
  q.Start(*q.Next());
  EXPECT_EQ(q.queued_missions(), 0);
  EXPECT_EQ(q.running_missions(), 6);
  EXPECT_TRUE(q.Finish(1));
  EXPECT_EQ(q.admitted_missions(), 0);
  EXPECT_EQ(q.running_groups(), 0);
  EXPECT_FALSE(q.Finish(1));
  EXPECT_FALSE(q.TryAdmit(-1));
}

TEST(FleetQueueTest, AtMostMaxRunningGroupsPlanAtOnce) {
  FleetQueue q(2, 100);
  ASSERT_TRUE(q.TryAdmit(4));
  for (uint64_t id = 1; id <= 4; ++id) q.Push(id, "a", 0, 1);
  EXPECT_EQ(StartAll(q), (std::vector<uint64_t>{1, 2}));
  EXPECT_EQ(q.running_groups(), 2);
  EXPECT_EQ(q.Next(), std::nullopt);
  q.Finish(2);
  EXPECT_EQ(StartAll(q), (std::vector<uint64_t>{3}));
}

TEST(FleetQueueTest, HigherPriorityFirstThenArrival) {
  FleetQueue q(1, 100);
  ASSERT_TRUE(q.TryAdmit(4));
  q.Push(1, "a", 0, 1);
  q.Push(2, "a", 5, 1);
  q.Push(3, "a", 9, 1);
  q.Push(4, "a", 5, 1);
  std::vector<uint64_t> order;
  while (std::optional<uint64_t> next = q.Next()) {
    q.Start(*next);
    order.push_back(*next);
    q.Finish(*next);
  }
  EXPECT_EQ(order, (std::vector<uint64_t>{3, 2, 4, 1}));
}

TEST(FleetQueueTest, OneIdentityCannotTakeEverySlotWhileAnotherWaits) {
  FleetQueue q(4, 100);
  // "big" queues ten groups first, at a higher priority; "small" one group after.
  ASSERT_TRUE(q.TryAdmit(11));
  for (uint64_t id = 1; id <= 10; ++id) q.Push(id, "big", 50, 1);
  q.Push(100, "small", 0, 1);
  // Fair share before priority: "small"'s group takes the second slot.
  EXPECT_EQ(StartAll(q), (std::vector<uint64_t>{1, 100, 2, 3}));
  EXPECT_EQ(q.RunningOf("big"), 3);
  EXPECT_EQ(q.RunningOf("small"), 1);
}

TEST(FleetQueueTest, AFreedSlotGoesToTheIdentityHoldingFewest) {
  FleetQueue q(3, 100);
  ASSERT_TRUE(q.TryAdmit(8));
  // "a" came first and took every slot (nobody else waited then).
  for (uint64_t id = 1; id <= 5; ++id) q.Push(id, "a", 0, 1);
  EXPECT_EQ(StartAll(q), (std::vector<uint64_t>{1, 2, 3}));
  // "b" and "c" arrive; the running groups are not preempted.
  q.Push(10, "b", 0, 1);
  q.Push(20, "c", 0, 1);
  q.Push(11, "b", 0, 1);
  EXPECT_EQ(q.Next(), std::nullopt);
  // Each slot "a" frees goes to whoever holds the fewest: b, then c, then
  // a itself, which by then holds none (b's second group waits: b holds one).
  q.Finish(1);
  EXPECT_EQ(StartAll(q), (std::vector<uint64_t>{10}));
  q.Finish(2);
  EXPECT_EQ(StartAll(q), (std::vector<uint64_t>{20}));
  q.Finish(3);
  EXPECT_EQ(StartAll(q), (std::vector<uint64_t>{4}));
  EXPECT_EQ(q.RunningOf("a"), 1);
  EXPECT_EQ(q.RunningOf("b"), 1);
  EXPECT_EQ(q.RunningOf("c"), 1);
}

TEST(FleetQueueTest, CallersTakeTurnsForASingleSlotWhateverTheirPriorities) {
  FleetQueue q(1, 100);
  ASSERT_TRUE(q.TryAdmit(5));
  q.Push(1, "a", 1000, 1);
  q.Push(2, "a", 1000, 1);
  q.Push(3, "a", 1000, 1);
  ASSERT_EQ(q.Next(), 1u);
  q.Start(1);
  // "b" comes while "a" plans; a's priority does not keep it waiting.
  q.Push(10, "b", 0, 1);
  q.Push(11, "b", 0, 1);
  std::vector<uint64_t> order = {1};
  q.Finish(1);
  while (std::optional<uint64_t> next = q.Next()) {
    q.Start(*next);
    order.push_back(*next);
    q.Finish(*next);
  }
  EXPECT_EQ(order, (std::vector<uint64_t>{1, 10, 2, 11, 3}));
}

TEST(FleetQueueTest, AQueuedGroupRemovedFreesItsMissionsAndNeverRuns) {
  FleetQueue q(1, 10);
  ASSERT_TRUE(q.TryAdmit(7));
  q.Push(1, "a", 0, 3);
  q.Push(2, "a", 0, 4);
  q.Start(*q.Next());
  EXPECT_TRUE(q.IsQueued(2));
  EXPECT_TRUE(q.Finish(2));  // its call was cancelled while it waited
  EXPECT_FALSE(q.IsQueued(2));
  EXPECT_EQ(q.admitted_missions(), 3);
  EXPECT_EQ(q.queued_missions(), 0);
  q.Finish(1);
  EXPECT_EQ(q.Next(), std::nullopt);
  EXPECT_EQ(q.admitted_missions(), 0);
}

}  // namespace
}  // namespace riskplan::server
