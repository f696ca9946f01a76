// KernelWeights: a copy of an ImpactTable's kernel weights laid out for the
// CPU kernel's vector loops, every kernel row starting on a 64-byte boundary
// (a cache line, one 512-bit load), in one of two formats:
// - kDouble: the table's own doubles, same values and row stride
//   (ImpactKernel::Stride(), a multiple of 8 doubles). The exact path reads
//   these: the values are identical, so the results are too; only the loads
//   no longer straddle cache lines (the table's std::vector starts at any
//   16-byte offset).
// - kFloat32: each weight rounded to the nearest float (relative error at
//   most 2^-24), rows padded with zeros to a multiple of 16 floats. The
//   float32 path reads these (docs/accel.md, "float32 path").
// The copy lives on 2 MiB pages (HugePageBuffer), like PreparedMap.
//
// KernelWeightsCache holds the copies of the tables in use, bounded by a byte
// budget, least recently used dropped first (a BoundedCache keyed by table and
// format, core/base/bounded_cache.h). Thread-safe; a KernelWeights is
// immutable once built and shared read-only between threads.
#ifndef RISKPLAN_ACCEL_KERNEL_WEIGHTS_H_
#define RISKPLAN_ACCEL_KERNEL_WEIGHTS_H_

#include <cstddef>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "accel/prepared_map.h"
#include "core/base/bounded_cache.h"
#include "core/base/check.h"
#include "core/risk/impact_table.h"

namespace riskplan::accel {

enum class WeightFormat { kDouble = 0, kFloat32 = 1 };

class KernelWeights {
 public:
  // Null when the memory cannot be had. Does not keep `table` alive.
  static std::shared_ptr<const KernelWeights> Build(const ImpactTable& table, WeightFormat format);
  // Bytes Build() takes for `table` (whole 2 MiB pages).
  static size_t BytesFor(const ImpactTable& table, WeightFormat format);
  // Row stride, in elements, of a kernel of `side` cells in `format`.
  static int StrideFor(int side, WeightFormat format);

  WeightFormat format() const { return format_; }
  // The weights of kernel (b, k): row-major, rows north, row r at
  // r * StrideFor(side) elements; entries past the side are 0.
  // REQUIRES: the matching format; 1 <= b <= height bins, 0 <= k < heading bins.
  const double* doubles(int b, int k) const {
    RISKPLAN_DCHECK(format_ == WeightFormat::kDouble);
    return static_cast<const double*>(buffer_.data()) + offsets_[Index(b, k)];
  }
  const float* floats(int b, int k) const {
    RISKPLAN_DCHECK(format_ == WeightFormat::kFloat32);
    return static_cast<const float*>(buffer_.data()) + offsets_[Index(b, k)];
  }
  size_t MemoryBytes() const { return buffer_.size(); }

 private:
  KernelWeights() = default;
  size_t Index(int b, int k) const {
    RISKPLAN_DCHECK(b >= 1 && k >= 0 && k < heading_bins_);
    const size_t index = static_cast<size_t>(b - 1) * heading_bins_ + k;
    RISKPLAN_DCHECK(index < offsets_.size());  // b <= height bins
    return index;
  }

  WeightFormat format_ = WeightFormat::kDouble;
  int heading_bins_ = 0;
  HugePageBuffer buffer_;
  std::vector<size_t> offsets_;  // in elements, per (b, k)
};

class KernelWeightsCache {
 public:
  // Holds at most `budget_bytes` of copies (0: none; Get() returns null and
  // kernels read the table's own weights, or convert nothing and fall back).
  explicit KernelWeightsCache(size_t budget_bytes) : cache_({.max_bytes = budget_bytes}) {}

  // The copy of `table` in `format`, built on first use by the calling thread
  // (about 10 ms for the default table; other callers for the same table and
  // format wait for it). Null when it alone exceeds the budget or memory is
  // short. A dropped copy stays valid for holders of its shared_ptr. Never
  // keeps `table` itself alive.
  std::shared_ptr<const KernelWeights> Get(const std::shared_ptr<const ImpactTable>& table,
                                           WeightFormat format);

  size_t MemoryBytes() const { return cache_.stats().bytes; }
  size_t budget_bytes() const { return cache_.limits().max_bytes; }

 private:
  // Keyed by the table's address and the format, with the table as the
  // entry's owner (see PreparedMapCache).
  using Key = std::pair<const ImpactTable*, WeightFormat>;
  BoundedCache<Key, KernelWeights> cache_;
};

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_KERNEL_WEIGHTS_H_
