// WorkQueue: the RiskEngine's chunks of work and who may take them.
//
// A batch (one RiskEngine::Evaluate call) is cut into chunks: slices of its
// configurations. A chunk is always in exactly one place: in the queue, or
// held by one runner (a CPU worker, an FPGA worker, or the calling thread).
// A runner either completes it (its results are written, once) or puts it
// back (Requeue); a batch returns when all its chunks are complete. So no
// result is lost or written twice, whatever fails.
//
// Who takes what: CPU workers take any chunk; an FPGA worker takes chunks
// only while it is up, and never a chunk marked cpu_only (one that failed on
// FPGA workers too often, or whose model no board can serve); the calling
// thread takes chunks of its own batch when the engine lets callers run, or
// when nobody else could (no CPU worker, no FPGA worker up).
//
// Taking over: while an FPGA worker waits for its board (a Lease, between
// BeginIo and EndIo), the chunk's results are not being written, and a caller
// whose stop condition is reached (its cancellation, deadline or time budget)
// takes the chunk back and computes it itself instead of waiting for a board
// that may be stalled, restarting or uploading for seconds. The worker then
// learns at EndIo that the chunk is no longer its own and never touches it
// again (its late reply is dropped), so the chunk is still completed once.
//
// Thread-safe.
#ifndef RISKPLAN_ACCEL_WORK_QUEUE_H_
#define RISKPLAN_ACCEL_WORK_QUEUE_H_

#include <atomic>
#include <cstdint>
#include <deque>
#include <span>
#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "core/base/cancellation.h"
#include "core/base/geometry.h"
#include "core/risk/risk_model.h"

namespace riskplan::accel {

struct Batch;

struct Chunk {
  Batch* batch = nullptr;
  size_t first = 0;  // slice [first, first + count) of the batch
  size_t count = 0;
  int fpga_failures = 0;
  bool cpu_only = false;

  std::span<const Pose> configs() const;
  std::span<ConfigurationRisk> out() const;
};

struct Batch {
  const RiskModel* model = nullptr;
  std::span<const Pose> configs;
  std::span<ConfigurationRisk> out;
  size_t remaining = 0;  // chunks not complete; guarded by the queue's mutex
};

inline std::span<const Pose> Chunk::configs() const { return batch->configs.subspan(first, count); }
inline std::span<ConfigurationRisk> Chunk::out() const { return batch->out.subspan(first, count); }

class WorkQueue {
 public:
  enum class Taker { kCpu, kFpga };

  explicit WorkQueue(bool caller_runs) : caller_runs_(caller_runs) {}

  // Queues the chunks of a batch (batch->remaining must equal their count).
  void Submit(std::span<Chunk> chunks);

  // For the calling thread of a batch: runs queued chunks of the batch with
  // `run` while it may (see above), else waits, until every chunk of the
  // batch is complete. Once `stop` (if given) is reached, the caller runs
  // every queued chunk of its batch and takes over those its FPGA workers are
  // waiting for (above), polling `stop` every few milliseconds while it
  // waits. Returns how many chunks the caller ran.
  template <typename Run>
  size_t RunUntilDone(Batch* batch, Run run, const StopCondition* stop = nullptr);

  // For workers: the next chunk for a taker of this kind, waiting at most
  // `wait`. Null on timeout, when Stop()ped, or when *cancel is true after a
  // Wake(). An FPGA taker calls it only while it is up.
  Chunk* Take(Taker taker, absl::Duration wait, const std::atomic<bool>* cancel = nullptr);

  // An FPGA worker's request in flight for a chunk it holds. Owned by the
  // worker; its fields are the queue's.
  struct Lease {
    Chunk* chunk = nullptr;
    bool taken_over = false;
  };
  // From now on, until EndIo, the chunk's caller may take it over; the worker
  // must not touch the chunk (nor its batch) in between.
  void BeginIo(Lease* lease, Chunk* chunk);
  // True: the chunk is still the worker's (to complete or requeue). False: a
  // caller took it over; the pointer may dangle, the worker drops its results.
  bool EndIo(Lease* lease);
  // Chunks taken over from FPGA workers by callers so far.
  uint64_t taken_over() const;
  // Wakes every waiter (after setting a cancel flag, say).
  void Wake();
  // The chunk's results are written.
  void Complete(Chunk* chunk);
  // Puts a chunk back at the front of the queue.
  void Requeue(Chunk* chunk);

  // How many FPGA workers are up, and whether CPU workers exist: decides
  // whether callers must run their chunks themselves.
  void AddCpuWorkers(int n);
  void FpgaUpChanged(int delta);
  int fpga_up() const;

  // Wakes every waiter; Take() returns null from now on.
  void Stop();
  bool stopped() const;

  // Sleeps until `deadline` or Stop(), whichever comes first.
  void SleepUntil(absl::Time deadline);

 private:
  bool CallerMayRun(const Chunk& chunk) const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  const bool caller_runs_;
  mutable absl::Mutex mu_;
  absl::CondVar changed_;
  std::deque<Chunk*> queue_ ABSL_GUARDED_BY(mu_);
  std::vector<Lease*> leases_ ABSL_GUARDED_BY(mu_);
  uint64_t taken_over_ ABSL_GUARDED_BY(mu_) = 0;
  int cpu_workers_ ABSL_GUARDED_BY(mu_) = 0;
  int fpga_up_ ABSL_GUARDED_BY(mu_) = 0;
  bool stopped_ ABSL_GUARDED_BY(mu_) = false;
};

template <typename Run>
size_t WorkQueue::RunUntilDone(Batch* batch, Run run, const StopCondition* stop) {
  size_t ran = 0;
  absl::MutexLock lock(&mu_);
  while (batch->remaining > 0) {
    const bool stopping = stop != nullptr && stop->Reached();
    Chunk* mine = nullptr;
    for (auto it = queue_.begin(); it != queue_.end(); ++it) {
      if ((*it)->batch == batch && (stopping || CallerMayRun(**it))) {
        mine = *it;
        queue_.erase(it);
        break;
      }
    }
    if (mine == nullptr && stopping) {
      for (auto it = leases_.begin(); it != leases_.end(); ++it) {
        if ((*it)->chunk->batch == batch) {
          mine = (*it)->chunk;
          (*it)->chunk = nullptr;
          (*it)->taken_over = true;
          leases_.erase(it);
          ++taken_over_;
          break;
        }
      }
    }
    if (mine == nullptr) {
      // A stop condition cannot signal: poll it.
      if (stop != nullptr && !stopping) {
        changed_.WaitWithTimeout(&mu_, absl::Milliseconds(5));
      } else {
        changed_.Wait(&mu_);
      }
      continue;
    }
    mu_.Unlock();
    run(mine);
    mu_.Lock();
    ++ran;
    --batch->remaining;
    changed_.SignalAll();
  }
  return ran;
}

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_WORK_QUEUE_H_
