// The shim's protocol logic, apart from sockets: BlobStore (the blobs a board
// holds) and ShimSession (one connection's requests, frame in, frame out).
// ShimServer (shim_server.h) puts them behind a TCP listener; tests drive
// sessions directly and build misbehaving shims around them.
#ifndef RISKPLAN_ACCEL_SHIM_SHIM_SESSION_H_
#define RISKPLAN_ACCEL_SHIM_SHIM_SESSION_H_

#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "accel/blobs.h"
#include "accel/shim/device.h"
#include "accel/shim_protocol.h"

namespace riskplan::accel {

struct ShimLimits {
  uint32_t max_sites_per_eval = 65536;
  uint32_t max_payload_bytes = 16u << 20;
  uint64_t store_bytes = uint64_t{1} << 30;  // installed blobs, quantised
  uint64_t max_blob_bytes = uint64_t{512} << 20;
};

// The installed blobs, quantised for the device, by hash. Thread-safe.
// Quantised sizes count against the store; when an install does not fit,
// the least recently used blobs are dropped (a request holding one keeps it
// alive through its shared_ptr).
class BlobStore {
 public:
  BlobStore(NumberFormat format, int max_kernel_side, uint64_t capacity_bytes)
      : format_(format), max_kernel_side_(max_kernel_side), capacity_bytes_(capacity_bytes) {}

  // Checks, quantises and installs a complete blob. InvalidArgument for bad
  // contents, ResourceExhausted when it alone exceeds the capacity.
  absl::Status Install(BlobKind kind, const BlobHash& hash, absl::string_view bytes);
  std::shared_ptr<const QuantizedMap> Map(const BlobHash& hash);
  std::shared_ptr<const QuantizedKernelTable> Kernels(const BlobHash& hash);
  uint64_t MemoryBytes() const;

 private:
  struct Entry {
    std::shared_ptr<const QuantizedMap> map;
    std::shared_ptr<const QuantizedKernelTable> kernels;
    uint64_t bytes = 0;
    uint64_t last_use = 0;
  };
  void MakeRoom(uint64_t bytes) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  const NumberFormat format_;
  const int max_kernel_side_;
  const uint64_t capacity_bytes_;
  mutable absl::Mutex mu_;
  std::map<BlobHash, Entry> entries_ ABSL_GUARDED_BY(mu_);
  uint64_t bytes_ ABSL_GUARDED_BY(mu_) = 0;
  uint64_t clock_ ABSL_GUARDED_BY(mu_) = 0;
  uint64_t next_table_id_ ABSL_GUARDED_BY(mu_) = 1;
};

// What every session of a shim shares. The device is used under device_mu.
struct ShimContext {
  EwmmDevice* device = nullptr;
  absl::Mutex device_mu;
  BlobStore* store = nullptr;
  ShimLimits limits;
  std::atomic<uint64_t> evals{0};
  std::atomic<uint64_t> sites{0};
  // Device clock cycles of the EVALs served (devices that count them).
  std::atomic<uint64_t> device_cycles{0};
};

class ShimSession {
 public:
  explicit ShimSession(ShimContext* context) : context_(context) {}

  // The reply frame to one request frame. *close is set when the connection
  // must be closed after the reply is sent (version mismatch, malformed
  // payload). Frames whose header already failed DecodeHeader never get
  // here: see ErrorFrame.
  std::string Handle(const FrameHeader& header, absl::string_view payload, bool* close);

  // An ERROR frame for request `id`.
  static std::string ErrorFrame(uint64_t id, ShimErrorCode code, absl::string_view message,
                                const BlobHash& blob = {});

 private:
  std::string HandleHello(uint64_t id, absl::string_view payload, bool* close);
  std::string HandlePutBlob(uint64_t id, absl::string_view payload, bool* close);
  std::string HandleEval(uint64_t id, absl::string_view payload, bool* close);

  ShimContext* const context_;
  // One upload in progress per session.
  BlobHash upload_hash_{};
  BlobKind upload_kind_ = BlobKind::kMap;
  uint64_t upload_total_ = 0;
  std::string upload_bytes_;
};

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_SHIM_SHIM_SESSION_H_
