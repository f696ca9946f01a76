// The blobs a board keeps: a map's density and shelter layers, and an impact
// table's kernels, in the canonical byte form that is uploaded and named by
// its SHA-256 (docs/shim-protocol.md, "Blobs"). The board quantises them to
// its number format when it installs them.
//
//   map blob      "RPMAP001" u32 nx u32 ny f32 density[nx*ny] f32 shelter[nx*ny]
//   kernels blob  "RPKRN001" u32 height_bins u32 heading_bins
//                 then per height bin b = 1..H: u32 half_width, and for each
//                 heading bin k = 0..N-1: f64 weights[side*side]
//                 (side = 2 hw + 1, rows running north, unpadded)
// Layers are row-major with row 0 the southernmost, as in RiskMap.
//
// BlobCache builds the blobs of the maps and tables in use once and shares
// them between FPGA workers (thread-safe, bounded by bytes: a BoundedCache
// keyed by the map or table, core/base/bounded_cache.h).
#ifndef RISKPLAN_ACCEL_BLOBS_H_
#define RISKPLAN_ACCEL_BLOBS_H_

#include <cstdint>
#include <list>
#include <memory>
#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/functional/function_ref.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/synchronization/mutex.h"
#include "accel/fixed_point.h"
#include "accel/shim_protocol.h"
#include "core/base/bounded_cache.h"
#include "core/map/risk_map.h"
#include "core/risk/impact_table.h"

namespace riskplan::accel {

// A kernel set as the blob carries it (also what tests and the known-answer
// probe build by hand).
struct KernelSet {
  int height_bins = 0;
  int heading_bins = 0;
  std::vector<int> half_width;               // per height bin (index b - 1)
  std::vector<std::vector<double>> weights;  // per (b, k): index (b-1)*N + k, side*side
};
KernelSet KernelSetOf(const ImpactTable& table);

std::string EncodeMapBlob(int nx, int ny, const float* density, const float* shelter);
std::string EncodeMapBlob(const RiskMap& map);
std::string EncodeKernelsBlob(const KernelSet& kernels);

// Quantised kernels, as the device holds them; index (b-1)*N + k.
struct QuantizedKernelTable {
  uint64_t id = 0;  // unique per installed table (devices cache kernels by it)
  int height_bins = 0;
  int heading_bins = 0;
  std::vector<QuantizedKernel> kernels;
  const QuantizedKernel& kernel(int b, int k) const {
    return kernels[static_cast<size_t>(b - 1) * heading_bins + k];
  }
  size_t MemoryBytes() const;
};

// Parse, check the domains (density >= 0, shelter in [0, 10], weights in
// [0, 1], all finite; sizes consistent; kernel side <= max_side) and quantise.
// InvalidArgument naming what is wrong.
absl::StatusOr<QuantizedMap> QuantizeMapBlob(absl::string_view blob, const NumberFormat& format,
                                             int pad);
absl::StatusOr<QuantizedKernelTable> QuantizeKernelsBlob(absl::string_view blob,
                                                         const NumberFormat& format, int max_side);

// A blob ready to upload.
struct Blob {
  BlobKind kind = BlobKind::kMap;
  BlobHash hash{};
  std::string bytes;
  double max_density = 0.0;  // map blobs: the largest density (checks results)
};

class BlobCache {
 public:
  explicit BlobCache(size_t budget_bytes) : cache_({.max_bytes = budget_bytes}) {}

  // The blob of `map` / `table`, built on first use (tens of milliseconds
  // for demo-city). Never keeps the map or table alive. Entries beyond the
  // budget are dropped, least recently used first (the one returned is kept
  // alive by its shared_ptr). Null when the blob alone is larger than the
  // budget: it is not kept, and later calls for the same map or table return
  // null at once (no rebuild), so the cache never holds more than its budget.
  std::shared_ptr<const Blob> MapBlob(const std::shared_ptr<const RiskMap>& map);
  std::shared_ptr<const Blob> KernelsBlob(const std::shared_ptr<const ImpactTable>& table);

  size_t MemoryBytes() const { return cache_.stats().bytes; }
  size_t budget_bytes() const { return cache_.limits().max_bytes; }

 private:
  std::shared_ptr<const Blob> Get(const std::shared_ptr<const void>& owner,
                                  absl::FunctionRef<Blob()> build);
  // Whether `owner`'s blob was found larger than the whole budget.
  bool RefusedLocked(const std::shared_ptr<const void>& owner) const
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(refused_mu_);

  // Keyed by the map's or table's address, with it as the entry's owner: the
  // entry goes stale when it is freed, so a new one at the same address is
  // never taken for it.
  BoundedCache<const void*, Blob> cache_;
  // Owners whose blob exceeded the whole budget. Kept here rather than in
  // the cache: they hold no bytes and are never evicted, only forgotten with
  // their owner.
  mutable absl::Mutex refused_mu_;
  std::list<std::weak_ptr<const void>> refused_ ABSL_GUARDED_BY(refused_mu_);
};

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_BLOBS_H_
