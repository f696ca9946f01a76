// RiskEngine: the accelerator layer behind the planners' RiskEvaluator and
// the EvaluateRisk RPC. It takes risk batches (configurations in,
// configuration risks with I and S~ out), cuts them into chunks, queues them
// over a pool of workers, and returns the results in order:
// - CPU workers: threads running CpuRiskKernel (bit for bit
//   RiskModel::Evaluate, or its float32 path when options.kernel.precision
//   says so), sharing a SiteCache, a PreparedMapCache and a
//   KernelWeightsCache;
// - FPGA workers: one per riskplan-fpga-shim endpoint (FpgaWorker), whose
//   results carry the board's fixed-point rounding (docs/accel.md);
// - the calling thread, which runs chunks of its own batch when
//   caller_runs is set, and always when no other worker could (so that the
//   CPU is the fallback even with cpu_workers = 0).
// A chunk whose FPGA worker fails, times out, returns garbage or is removed
// goes back to the queue; every result is written exactly once.
//
// Which results a batch gets: a chunk evaluated on the CPU is exact (within
// 1e-5 relative with the float32 path); one
// evaluated on a board is within the board's documented bound. With FPGA
// workers configured, which chunks go where depends on timing, so bit-for-bit
// reproducibility of a plan holds on the CPU path only (DESIGN.md).
//
// Thread-safe: Evaluate() may be called from many threads at once.
#ifndef RISKPLAN_ACCEL_RISK_ENGINE_H_
#define RISKPLAN_ACCEL_RISK_ENGINE_H_

#include <atomic>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "accel/blobs.h"
#include "accel/cpu_kernel.h"
#include "accel/fpga_worker.h"
#include "accel/kernel_weights.h"
#include "accel/prepared_map.h"
#include "accel/site_cache.h"
#include "accel/work_queue.h"
#include "core/risk/risk_evaluator.h"

namespace riskplan::accel {

struct RiskEngineOptions {
  // CPU worker threads (0: only callers and FPGA workers compute).
  int cpu_workers = 1;
  // Callers run chunks of their own batch too (lowest latency for the
  // planners' small batches). Off: chunks go to the workers, and callers
  // compute only when no worker can.
  bool caller_runs = true;
  // "HOST:PORT" of each riskplan-fpga-shim.
  std::vector<std::string> fpga_shims;
  // Caches, each bounded (bytes).
  size_t site_cache_bytes = size_t{64} << 20;
  size_t prepared_map_bytes = size_t{256} << 20;
  size_t blob_cache_bytes = size_t{256} << 20;
  // The CPU kernels' 64-byte-aligned weight copies (KernelWeightsCache): one
  // per impact table in use and format (double for kernel.precision kExact,
  // float32 for kFloat32; 34 MB and 19 MB for the default table).
  size_t kernel_weights_bytes = size_t{128} << 20;
  // Chunk sizes: a batch is cut into about two chunks per worker, each of
  // min_chunk_configs to max_chunk_configs configurations.
  int min_chunk_configs = 512;
  int max_chunk_configs = 16384;
  CpuKernelOptions kernel;
  FpgaWorkerOptions fpga;
  // Called on every FPGA worker state change, on the worker's thread (null:
  // one line on stderr per change).
  WorkerEventFn on_worker_event;
};

struct CpuWorkerStats {
  std::string name;  // "cpu-0", ...
  uint64_t chunks = 0;
  uint64_t configurations = 0;
  double busy_seconds = 0.0;
};

struct RiskEngineStats {
  uint64_t batches = 0;
  uint64_t configurations = 0;
  uint64_t chunks = 0;
  uint64_t caller_chunks = 0;  // chunks run by calling threads
  uint64_t caller_configurations = 0;
  uint64_t requeues = 0;  // chunks given back by FPGA workers
  // Chunks that callers whose stop was reached took over from FPGA workers
  // still waiting for their boards.
  uint64_t taken_over = 0;
  uint64_t cache_hits = 0;
  uint64_t cache_misses = 0;
  size_t site_cache_bytes = 0;
  size_t prepared_map_bytes = 0;
  size_t blob_cache_bytes = 0;
  size_t kernel_weights_bytes = 0;
  // The bounds of the same caches (RiskEngineOptions).
  size_t site_cache_limit_bytes = 0;
  size_t prepared_map_limit_bytes = 0;
  size_t blob_cache_limit_bytes = 0;
  size_t kernel_weights_limit_bytes = 0;
  std::vector<CpuWorkerStats> cpu;
  std::vector<FpgaWorkerStats> fpga;
};

class RiskEngine {
 public:
  // Starts the workers (FPGA workers begin by probing their board; an
  // unreachable board is not an error, its worker stays down and retries).
  // InvalidArgument for bad options.
  static absl::StatusOr<std::unique_ptr<RiskEngine>> Create(const RiskEngineOptions& options);
  // Stops every worker. REQUIRES: no Evaluate() in progress.
  ~RiskEngine();

  // out[i] = the configuration risk of configs[i] under `model`, for every i.
  // REQUIRES: out.size() == configs.size(); `model` lives until it returns.
  // Never fails for a worker's failure (the CPU takes over); an error only
  // for bad arguments. Once `stop` (if given: the caller's cancellation,
  // deadline or time budget) is reached, the calling thread computes the
  // batch's remaining chunks itself, those a board is working on included,
  // instead of waiting for boards (WorkQueue, "Taking over"): the batch is
  // still complete, and exact where the CPU computed it, within milliseconds
  // rather than a stalled board's request deadline.
  absl::Status Evaluate(const RiskModel& model, std::span<const Pose> configs,
                        std::span<ConfigurationRisk> out, const StopCondition* stop = nullptr);

  // A RiskEvaluator for one planner run or evaluation, counting its own
  // configurations; its batches are evaluated with `stop` (above; the
  // default is never reached). The engine and stop's tokens must outlive it.
  std::unique_ptr<RiskEvaluator> NewEvaluator(StopCondition stop = StopCondition());

  // Adds a worker for one more board (AlreadyExists if present), or removes
  // one (NotFound if absent): its chunk in flight goes back to the queue.
  absl::Status AddFpgaWorker(const std::string& endpoint);
  absl::Status RemoveFpgaWorker(const std::string& endpoint);

  RiskEngineStats Stats() const;

 private:
  explicit RiskEngine(const RiskEngineOptions& options);
  void CpuWorkerLoop(int index);
  // A kernel for a calling thread, from a pool (callers are few).
  std::unique_ptr<CpuRiskKernel> TakeKernel();
  void ReturnKernel(std::unique_ptr<CpuRiskKernel> kernel);

  const RiskEngineOptions options_;
  // Evaluate() calls in progress: the destructor checks there are none.
  std::atomic<int> evaluating_{0};
  SiteCache site_cache_;
  PreparedMapCache prepared_maps_;
  KernelWeightsCache kernel_weights_;
  BlobCache blobs_;
  WorkQueue queue_;
  std::vector<std::thread> cpu_threads_;

  mutable absl::Mutex mu_;
  std::vector<std::unique_ptr<FpgaWorker>> fpga_ ABSL_GUARDED_BY(mu_);
  std::vector<CpuWorkerStats> cpu_stats_ ABSL_GUARDED_BY(mu_);
  std::vector<std::unique_ptr<CpuRiskKernel>> spare_kernels_ ABSL_GUARDED_BY(mu_);
  uint64_t batches_ ABSL_GUARDED_BY(mu_) = 0;
  uint64_t configurations_ ABSL_GUARDED_BY(mu_) = 0;
  uint64_t chunks_ ABSL_GUARDED_BY(mu_) = 0;
  uint64_t caller_chunks_ ABSL_GUARDED_BY(mu_) = 0;
  uint64_t caller_configurations_ ABSL_GUARDED_BY(mu_) = 0;
};

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_RISK_ENGINE_H_
