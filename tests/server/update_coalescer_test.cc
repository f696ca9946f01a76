// The write discipline of a plan stream: one write in flight, newest update
// wins, minimum interval, final message never dropped.
#include "server/plan/update_coalescer.h"

#include <string>

#include "gtest/gtest.h"

namespace riskplan::server {
namespace {

using Coalescer = UpdateCoalescer<std::string>;
const absl::Time t0 = absl::FromUnixSeconds(1000);

TEST(UpdateCoalescerTest, FirstUpdateIsWrittenAtOnce) {
  Coalescer c(absl::ZeroDuration());
  Coalescer::Step step = c.Offer("a", t0);
  ASSERT_TRUE(step.write.has_value());
  EXPECT_EQ(*step.write, "a");
  EXPECT_FALSE(step.is_final);
  EXPECT_FALSE(step.finish);
  EXPECT_TRUE(c.write_in_flight());
}

TEST(UpdateCoalescerTest, SlowReaderGetsNewestNotBacklog) {
  Coalescer c(absl::ZeroDuration());
  ASSERT_TRUE(c.Offer("a", t0).write.has_value());
  // Three improvements while "a" is in flight: only the newest survives.
  EXPECT_FALSE(c.Offer("b", t0).write.has_value());
  EXPECT_FALSE(c.Offer("c", t0).write.has_value());
  EXPECT_FALSE(c.Offer("d", t0).write.has_value());
  EXPECT_EQ(c.replaced(), 2);
  Coalescer::Step step = c.OnWriteDone(t0);
  ASSERT_TRUE(step.write.has_value());
  EXPECT_EQ(*step.write, "d");
  // Nothing more pending.
  EXPECT_FALSE(c.OnWriteDone(t0).write.has_value());
  EXPECT_FALSE(c.write_in_flight());
}

TEST(UpdateCoalescerTest, FinalReplacesPendingAndWaitsForWriteInFlight) {
  Coalescer c(absl::ZeroDuration());
  ASSERT_TRUE(c.Offer("a", t0).write.has_value());
  EXPECT_FALSE(c.Offer("b", t0).write.has_value());
  Coalescer::Step step = c.OfferFinal("final", t0);
  EXPECT_FALSE(step.write.has_value());  // "a" still in flight
  EXPECT_EQ(c.replaced(), 1);            // "b" dropped: the final carries the best
  step = c.OnWriteDone(t0);
  ASSERT_TRUE(step.write.has_value());
  EXPECT_EQ(*step.write, "final");
  EXPECT_TRUE(step.is_final);
  step = c.OnWriteDone(t0);
  EXPECT_TRUE(step.finish);
  EXPECT_FALSE(step.write.has_value());
}

TEST(UpdateCoalescerTest, FinalWithNothingInFlightIsWrittenAtOnce) {
  Coalescer c(absl::Seconds(10));
  ASSERT_TRUE(c.Offer("a", t0).write.has_value());
  ASSERT_FALSE(c.OnWriteDone(t0).write.has_value());
  // The interval would hold an update back, never the final message.
  Coalescer::Step step = c.OfferFinal("final", t0 + absl::Milliseconds(1));
  ASSERT_TRUE(step.write.has_value());
  EXPECT_TRUE(step.is_final);
}

TEST(UpdateCoalescerTest, OffersAfterFinalAreIgnored) {
  Coalescer c(absl::ZeroDuration());
  ASSERT_TRUE(c.OfferFinal("final", t0).write.has_value());
  EXPECT_FALSE(c.Offer("late", t0).write.has_value());
  EXPECT_FALSE(c.OfferFinal("again", t0).write.has_value());
  EXPECT_TRUE(c.OnWriteDone(t0).finish);
}

TEST(UpdateCoalescerTest, MinimumIntervalWithholdsAndAsksForOneWakeUp) {
  Coalescer c(absl::Milliseconds(100));
  ASSERT_TRUE(c.Offer("a", t0).write.has_value());
  EXPECT_FALSE(c.OnWriteDone(t0 + absl::Milliseconds(5)).write.has_value());
  Coalescer::Step step = c.Offer("b", t0 + absl::Milliseconds(10));
  EXPECT_FALSE(step.write.has_value());
  ASSERT_TRUE(step.wake_at.has_value());
  EXPECT_EQ(*step.wake_at, t0 + absl::Milliseconds(100));
  // A second withheld update does not ask for another wake-up.
  step = c.Offer("c", t0 + absl::Milliseconds(20));
  EXPECT_FALSE(step.write.has_value());
  EXPECT_FALSE(step.wake_at.has_value());
  // Too early: still withheld, and a new wake-up is requested.
  step = c.Poll(t0 + absl::Milliseconds(50));
  EXPECT_FALSE(step.write.has_value());
  ASSERT_TRUE(step.wake_at.has_value());
  step = c.Poll(t0 + absl::Milliseconds(100));
  ASSERT_TRUE(step.write.has_value());
  EXPECT_EQ(*step.write, "c");
  EXPECT_EQ(c.replaced(), 1);
}

TEST(UpdateCoalescerTest, IntervalElapsedSendsAtOnce) {
  Coalescer c(absl::Milliseconds(100));
  ASSERT_TRUE(c.Offer("a", t0).write.has_value());
  EXPECT_FALSE(c.OnWriteDone(t0).write.has_value());
  Coalescer::Step step = c.Offer("b", t0 + absl::Milliseconds(150));
  ASSERT_TRUE(step.write.has_value());
  EXPECT_EQ(*step.write, "b");
}

}  // namespace
}  // namespace riskplan::server
