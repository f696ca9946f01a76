#include "server/plan/thread_pool.h"

#include <atomic>

#include "absl/synchronization/notification.h"
#include "gtest/gtest.h"
#include "server/plan/timer_queue.h"

namespace riskplan::server {
namespace {

TEST(ThreadPoolTest, RunsEveryAcceptedTaskBeforeDestruction) {
  std::atomic<int> ran{0};
  {
    ThreadPool pool(2);
    for (int i = 0; i < 100; ++i) ASSERT_TRUE(pool.TrySubmit([&ran] { ++ran; }));
  }
  EXPECT_EQ(ran.load(), 100);
}

TEST(ThreadPoolTest, BoundedQueueRefusesWhenFull) {
  absl::Notification release;
  absl::Notification started;
  ThreadPool pool(1, /*max_queued=*/2);
  ASSERT_TRUE(pool.TrySubmit([&] {
    started.Notify();
    release.WaitForNotification();
  }));
  started.WaitForNotification();  // the worker is busy, the queue is empty
  EXPECT_TRUE(pool.TrySubmit([] {}));
  EXPECT_TRUE(pool.TrySubmit([] {}));
  EXPECT_FALSE(pool.TrySubmit([] {}));
  EXPECT_EQ(pool.queued(), 2u);
  release.Notify();
}

TEST(TimerQueueTest, RunsCallbacksInDueOrder) {
  TimerQueue timers;
  absl::Mutex mu;
  std::vector<int> order;
  absl::Notification done;
  const absl::Time now = absl::Now();
  timers.Schedule(now + absl::Milliseconds(40), [&] {
    absl::MutexLock lock(&mu);
    order.push_back(2);
    done.Notify();
  });
  timers.Schedule(now + absl::Milliseconds(10), [&] {
    absl::MutexLock lock(&mu);
    order.push_back(1);
  });
  ASSERT_TRUE(done.WaitForNotificationWithTimeout(absl::Seconds(5)));
  EXPECT_GE(absl::Now(), now + absl::Milliseconds(40));
  absl::MutexLock lock(&mu);
  EXPECT_EQ(order, (std::vector<int>{1, 2}));
}

TEST(TimerQueueTest, DestructionDropsPendingTimers) {
  std::atomic<int> ran{0};
  {
    TimerQueue timers;
    timers.Schedule(absl::Now() + absl::Hours(1), [&ran] { ++ran; });
    EXPECT_EQ(timers.pending(), 1u);
  }
  EXPECT_EQ(ran.load(), 0);
}

}  // namespace
}  // namespace riskplan::server
