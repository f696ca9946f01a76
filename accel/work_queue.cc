#include "accel/work_queue.h"

#include <algorithm>

namespace riskplan::accel {

void WorkQueue::Submit(std::span<Chunk> chunks) {
  absl::MutexLock lock(&mu_);
  for (Chunk& c : chunks) queue_.push_back(&c);
  changed_.SignalAll();
}

bool WorkQueue::CallerMayRun(const Chunk& chunk) const {
  if (caller_runs_) return true;
  // Without CPU workers the caller is the CPU fallback: it takes the chunks
  // no FPGA worker may take, and every chunk while none is up.
  return cpu_workers_ == 0 && (chunk.cpu_only || fpga_up_ == 0);
}

Chunk* WorkQueue::Take(Taker taker, absl::Duration wait, const std::atomic<bool>* cancel) {
  const absl::Time deadline = absl::Now() + wait;
  absl::MutexLock lock(&mu_);
  while (!stopped_ && !(cancel != nullptr && cancel->load())) {
    for (auto it = queue_.begin(); it != queue_.end(); ++it) {
      if (taker == Taker::kFpga && (*it)->cpu_only) continue;
      Chunk* chunk = *it;
      queue_.erase(it);
      return chunk;
    }
    if (changed_.WaitWithDeadline(&mu_, deadline)) return nullptr;
  }
  return nullptr;
}

void WorkQueue::BeginIo(Lease* lease, Chunk* chunk) {
  absl::MutexLock lock(&mu_);
  lease->chunk = chunk;
  lease->taken_over = false;
  leases_.push_back(lease);
  // A caller whose stop was reached while the worker prepared the chunk may
  // take it over now.
  changed_.SignalAll();
}

bool WorkQueue::EndIo(Lease* lease) {
  absl::MutexLock lock(&mu_);
  if (lease->taken_over) return false;  // the caller removed it from leases_
  leases_.erase(std::find(leases_.begin(), leases_.end(), lease));
  lease->chunk = nullptr;
  return true;
}

uint64_t WorkQueue::taken_over() const {
  absl::MutexLock lock(&mu_);
  return taken_over_;
}

void WorkQueue::Wake() {
  absl::MutexLock lock(&mu_);
  changed_.SignalAll();
}

void WorkQueue::Complete(Chunk* chunk) {
  absl::MutexLock lock(&mu_);
  --chunk->batch->remaining;
  changed_.SignalAll();
}

void WorkQueue::Requeue(Chunk* chunk) {
  absl::MutexLock lock(&mu_);
  queue_.push_front(chunk);
  changed_.SignalAll();
}

void WorkQueue::AddCpuWorkers(int n) {
  absl::MutexLock lock(&mu_);
  cpu_workers_ += n;
  changed_.SignalAll();
}

void WorkQueue::FpgaUpChanged(int delta) {
  absl::MutexLock lock(&mu_);
  fpga_up_ += delta;
  changed_.SignalAll();
}

int WorkQueue::fpga_up() const {
  absl::MutexLock lock(&mu_);
  return fpga_up_;
}

void WorkQueue::Stop() {
  absl::MutexLock lock(&mu_);
  stopped_ = true;
  changed_.SignalAll();
}

bool WorkQueue::stopped() const {
  absl::MutexLock lock(&mu_);
  return stopped_;
}

void WorkQueue::SleepUntil(absl::Time deadline) {
  absl::MutexLock lock(&mu_);
  while (!stopped_) {
    if (changed_.WaitWithDeadline(&mu_, deadline)) return;
  }
}

}  // namespace riskplan::accel
