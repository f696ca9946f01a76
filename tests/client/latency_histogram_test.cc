#include "client/load/latency_histogram.h"

#include <cmath>

#include "gtest/gtest.h"

namespace riskplan::client {
namespace {

TEST(LatencyHistogramTest, EmptyIsZero) {
  LatencyHistogram h;
  EXPECT_EQ(h.count(), 0);
  EXPECT_EQ(h.Percentile(50), 0.0);
  EXPECT_EQ(h.mean(), 0.0);
}

TEST(LatencyHistogramTest, PercentilesOfAUniformSpreadWithinOnePercent) {
  LatencyHistogram h;
  for (int i = 1; i <= 10000; ++i) h.Add(i * 1e-4);  // 0.1 ms .. 1 s
  EXPECT_EQ(h.count(), 10000);
  EXPECT_NEAR(h.Percentile(50), 0.5, 0.5 * 0.01);
  EXPECT_NEAR(h.Percentile(90), 0.9, 0.9 * 0.01);
  EXPECT_NEAR(h.Percentile(99), 0.99, 0.99 * 0.01);
  EXPECT_NEAR(h.Percentile(99.9), 0.999, 0.999 * 0.01);
  EXPECT_DOUBLE_EQ(h.min(), 1e-4);
  EXPECT_DOUBLE_EQ(h.max(), 1.0);
  EXPECT_NEAR(h.mean(), 0.50005, 1e-9);
  EXPECT_DOUBLE_EQ(h.Percentile(100), 1.0);
}

TEST(LatencyHistogramTest, TailIsNotHiddenByTheBody) {
  LatencyHistogram h;
  for (int i = 0; i < 998; ++i) h.Add(0.001);
  h.Add(2.0);
  h.Add(3.0);
  EXPECT_NEAR(h.Percentile(50), 0.001, 0.001 * 0.01);
  EXPECT_NEAR(h.Percentile(99.9), 2.0, 2.0 * 0.01);
  EXPECT_DOUBLE_EQ(h.Percentile(100), 3.0);
}

TEST(LatencyHistogramTest, PercentilesStayInsideMinAndMax) {
  LatencyHistogram h;
  h.Add(0.0123);
  EXPECT_DOUBLE_EQ(h.Percentile(0), 0.0123);
  EXPECT_DOUBLE_EQ(h.Percentile(50), 0.0123);
  EXPECT_DOUBLE_EQ(h.Percentile(100), 0.0123);
}

TEST(LatencyHistogramTest, MergeEqualsAddingEverything) {
  LatencyHistogram a, b, all;
  for (int i = 1; i <= 500; ++i) {
    a.Add(i * 1e-3);
    all.Add(i * 1e-3);
  }
  for (int i = 501; i <= 1000; ++i) {
    b.Add(i * 1e-3);
    all.Add(i * 1e-3);
  }
  a.Merge(b);
  EXPECT_EQ(a.count(), all.count());
  for (double p : {1.0, 50.0, 90.0, 99.0, 99.9}) EXPECT_EQ(a.Percentile(p), all.Percentile(p));
  EXPECT_EQ(a.max(), 1.0);
}

}  // namespace
}  // namespace riskplan::client
