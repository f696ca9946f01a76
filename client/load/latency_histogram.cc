#include "client/load/latency_histogram.h"

#include <algorithm>
#include <cassert>
#include <cmath>

namespace riskplan::client {
namespace {

// Log-spaced buckets keep the relative error the same at every latency: a
// 1% bucket is 10 ns wide at 1 us and 10 ms at 1 s, so microsecond Pings and
// multi-second plans share one histogram without losing either.
constexpr double kLowest = 1e-6;  // s; everything below is in bucket 0
constexpr double kGrowth = 1.01;  // bucket width ratio
const double kLogGrowth = std::log(kGrowth);
// Buckets up to 1000 s; slower values land in the last one.
const int kBuckets = static_cast<int>(std::ceil(std::log(1000.0 / kLowest) / kLogGrowth)) + 1;

}  // namespace

LatencyHistogram::LatencyHistogram() : buckets_(kBuckets, 0) {}

int LatencyHistogram::BucketOf(double seconds) {
  // Written so that NaN lands in bucket 0 too, never at a wild index.
  if (!(seconds > kLowest)) return 0;
  const int b = static_cast<int>(std::log(seconds / kLowest) / kLogGrowth) + 1;
  return std::min(b, kBuckets - 1);
}

double LatencyHistogram::BucketLow(int bucket) {
  return bucket == 0 ? 0.0 : kLowest * std::pow(kGrowth, bucket - 1);
}

void LatencyHistogram::Add(double seconds) {
  // A latency can come out negative when the clock steps back between send
  // and completion; it is counted (the call did complete) as 0.
  if (!(seconds >= 0.0)) seconds = 0.0;
  ++buckets_[BucketOf(seconds)];
  min_ = count_ == 0 ? seconds : std::min(min_, seconds);
  max_ = count_ == 0 ? seconds : std::max(max_, seconds);
  ++count_;
  sum_ += seconds;
}

void LatencyHistogram::Merge(const LatencyHistogram& other) {
  if (other.count_ == 0) return;
  // Every histogram has kBuckets buckets, so they add bucket by bucket.
  assert(other.buckets_.size() == buckets_.size());
  for (size_t i = 0; i < buckets_.size(); ++i) buckets_[i] += other.buckets_[i];
  min_ = count_ == 0 ? other.min_ : std::min(min_, other.min_);
  max_ = count_ == 0 ? other.max_ : std::max(max_, other.max_);
  count_ += other.count_;
  sum_ += other.sum_;
}

void LatencyHistogram::Clear() { *this = LatencyHistogram(); }

double LatencyHistogram::Percentile(double p) const {
  if (count_ == 0) return 0.0;
  p = std::clamp(p, 0.0, 100.0);
  // The rank of the wanted value, 1-based: the smallest value with at least
  // p% of the values at or below it.
  // (The small tolerance keeps 99.9% of 1000 at rank 999 despite rounding.)
  const int64_t rank =
      std::max<int64_t>(1, static_cast<int64_t>(std::ceil(p / 100.0 * count_ - 1e-9)));
  int64_t seen = 0;
  for (int b = 0; b < kBuckets; ++b) {
    seen += buckets_[b];
    if (seen >= rank) {
      // Interpolate inside the bucket by the rank's position in it.
      const double low = BucketLow(b), high = BucketLow(b + 1);
      const double inside =
          static_cast<double>(rank - (seen - buckets_[b])) / static_cast<double>(buckets_[b]);
      return std::clamp(low + (high - low) * inside, min_, max_);
    }
  }
  return max_;  // not reached: rank <= count_, the sum of the buckets
}

}  // namespace riskplan::client
