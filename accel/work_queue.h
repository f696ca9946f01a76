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
// Thread-safe.
#ifndef RISKPLAN_ACCEL_WORK_QUEUE_H_
#define RISKPLAN_ACCEL_WORK_QUEUE_H_

#include <atomic>
#include <cstdint>
#include <deque>
#include <span>
#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
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
  // batch is complete. Returns how many chunks the caller ran.
  template <typename Run>
  size_t RunUntilDone(Batch* batch, Run run);

  // For workers: the next chunk for a taker of this kind, waiting at most
  // `wait`. Null on timeout, when Stop()ped, or when *cancel is true after a
  // Wake(). An FPGA taker calls it only while it is up.
  Chunk* Take(Taker taker, absl::Duration wait, const std::atomic<bool>* cancel = nullptr);
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
  int cpu_workers_ ABSL_GUARDED_BY(mu_) = 0;
  int fpga_up_ ABSL_GUARDED_BY(mu_) = 0;
  bool stopped_ ABSL_GUARDED_BY(mu_) = false;
};

template <typename Run>
size_t WorkQueue::RunUntilDone(Batch* batch, Run run) {
  size_t ran = 0;
  absl::MutexLock lock(&mu_);
  while (batch->remaining > 0) {
    Chunk* mine = nullptr;
    for (auto it = queue_.begin(); it != queue_.end(); ++it) {
      if ((*it)->batch == batch && CallerMayRun(**it)) {
        mine = *it;
        queue_.erase(it);
        break;
      }
    }
    if (mine == nullptr) {
      changed_.Wait(&mu_);
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
