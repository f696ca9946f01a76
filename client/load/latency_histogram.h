// LatencyHistogram: latencies in log-spaced buckets (1% wide, 1 us .. 1000 s),
// so that percentiles cost O(buckets) and memory stays fixed however long a
// load test runs. Percentiles are exact to within one bucket (1%), and never
// outside [min, max] of the recorded values.
//
// Thread-compatible: callers serialise access (the load generator keeps one
// per phase under its mutex).
#ifndef RISKPLAN_CLIENT_LOAD_LATENCY_HISTOGRAM_H_
#define RISKPLAN_CLIENT_LOAD_LATENCY_HISTOGRAM_H_

#include <cstdint>
#include <vector>

namespace riskplan::client {

class LatencyHistogram {
 public:
  LatencyHistogram();

  // Records one latency, seconds (negative values count as 0).
  void Add(double seconds);
  void Merge(const LatencyHistogram& other);
  void Clear();

  int64_t count() const { return count_; }
  double min() const { return count_ == 0 ? 0.0 : min_; }
  double max() const { return count_ == 0 ? 0.0 : max_; }
  double mean() const { return count_ == 0 ? 0.0 : sum_ / static_cast<double>(count_); }
  // The p-th percentile, p in [0, 100], seconds (0 when empty).
  double Percentile(double p) const;

 private:
  static int BucketOf(double seconds);
  static double BucketLow(int bucket);

  std::vector<int64_t> buckets_;
  int64_t count_ = 0;
  double sum_ = 0.0;
  double min_ = 0.0;
  double max_ = 0.0;
};

}  // namespace riskplan::client

#endif  // RISKPLAN_CLIENT_LOAD_LATENCY_HISTOGRAM_H_
