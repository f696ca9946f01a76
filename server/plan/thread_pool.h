// A fixed pool of worker threads with a FIFO queue of tasks.
//
// The server runs planning and risk evaluation on pools of its own so that
// gRPC's threads never block on computation.
#ifndef RISKPLAN_SERVER_PLAN_THREAD_POOL_H_
#define RISKPLAN_SERVER_PLAN_THREAD_POOL_H_

#include <cstddef>
#include <deque>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"

namespace riskplan::server {

class ThreadPool {
 public:
  // Starts `threads` (>= 1) workers. `max_queued` bounds the tasks waiting for
  // a worker (0: unbounded).
  ThreadPool(int threads, size_t max_queued = 0);
  // Runs every task still queued, then joins the workers.
  ~ThreadPool();

  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  // Queues `task`. Returns false, and drops the task, when the queue is full.
  // Thread-safe.
  bool TrySubmit(std::function<void()> task);

  int threads() const { return static_cast<int>(workers_.size()); }
  // Tasks waiting for a worker (not those running). Thread-safe.
  size_t queued() const;

 private:
  void WorkerLoop();
  bool HasWorkOrStopping() const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  const size_t max_queued_;
  mutable absl::Mutex mu_;
  std::deque<std::function<void()>> queue_ ABSL_GUARDED_BY(mu_);
  bool stopping_ ABSL_GUARDED_BY(mu_) = false;
  std::vector<std::thread> workers_;
};

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_PLAN_THREAD_POOL_H_
