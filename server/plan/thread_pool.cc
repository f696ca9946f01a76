#include "server/plan/thread_pool.h"

#include <exception>
#include <utility>

#include "server/observability/rpc_log.h"

namespace riskplan::server {

ThreadPool::ThreadPool(int threads, size_t max_queued) : max_queued_(max_queued) {
  // At least one worker: a pool without workers would accept tasks that
  // never run, and a PlanCall whose Run never runs never ends its call.
  if (threads < 1) threads = 1;
  workers_.reserve(threads);
  for (int i = 0; i < threads; ++i) workers_.emplace_back([this] { WorkerLoop(); });
}

// Runs every task already accepted before joining: each task is what ends
// its call (PlanCall::Run, an evaluation's Complete), and an accepted call
// must be ended.
ThreadPool::~ThreadPool() {
  {
    absl::MutexLock lock(&mu_);
    stopping_ = true;
  }
  for (std::thread& t : workers_) t.join();
}

bool ThreadPool::TrySubmit(std::function<void()> task) {
  absl::MutexLock lock(&mu_);
  if (stopping_ || (max_queued_ > 0 && queue_.size() >= max_queued_)) return false;
  queue_.push_back(std::move(task));
  return true;
}

size_t ThreadPool::queued() const {
  absl::MutexLock lock(&mu_);
  return queue_.size();
}

bool ThreadPool::HasWorkOrStopping() const { return stopping_ || !queue_.empty(); }

void ThreadPool::WorkerLoop() {
  while (true) {
    std::function<void()> task;
    {
      absl::MutexLock lock(&mu_);
      mu_.Await(absl::Condition(this, &ThreadPool::HasWorkOrStopping));
      // Drain the queue before stopping: every accepted task runs.
      if (queue_.empty()) return;
      task = std::move(queue_.front());
      queue_.pop_front();
    }
    // Run without the lock: tasks take seconds, and other workers and
    // TrySubmit must go on meanwhile. Tasks end their own calls on an
    // exception (StatusFromException); one that still escapes is logged
    // rather than allowed to terminate the server.
    try {
      task();
    } catch (const std::exception& e) {
      LogEvent("task_exception", e.what());
    } catch (...) {
      LogEvent("task_exception", "an exception that is not a std::exception");
    }
  }
}

}  // namespace riskplan::server
