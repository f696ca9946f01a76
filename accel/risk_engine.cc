#include "accel/risk_engine.h"

#include <algorithm>
#include <iostream>

#include "absl/strings/str_cat.h"
#include "core/base/check.h"
#include "net/net.h"

namespace riskplan::accel {
namespace {

void LogToStderr(const WorkerEvent& e) {
  // One write per line, so that concurrent workers never interleave.
  std::cerr << absl::StrCat("riskplan-accel: worker ", e.worker, " ", WorkerStateName(e.from),
                            " -> ", WorkerStateName(e.to), e.reason.empty() ? "" : ": ", e.reason,
                            "\n");
}

// The per-planner-run adapter: the engine does the work, the adapter counts
// this run's configurations (RiskEvaluator::evaluated()).
class EngineEvaluator final : public RiskEvaluator {
 public:
  EngineEvaluator(RiskEngine* engine, StopCondition stop) : engine_(engine), stop_(stop) {}
  absl::Status EvaluateBatch(const RiskModel& model, std::span<const Pose> configs,
                             std::span<ConfigurationRisk> out) override {
    if (absl::Status s = engine_->Evaluate(model, configs, out, &stop_); !s.ok()) return s;
    evaluated_ += configs.size();
    return absl::OkStatus();
  }
  uint64_t evaluated() const override { return evaluated_; }

 private:
  RiskEngine* const engine_;
  const StopCondition stop_;
  uint64_t evaluated_ = 0;
};

}  // namespace

RiskEngine::RiskEngine(const RiskEngineOptions& options)
    : options_(options),
      site_cache_(options.site_cache_bytes),
      prepared_maps_(options.prepared_map_bytes),
      kernel_weights_(options.kernel_weights_bytes),
      blobs_(options.blob_cache_bytes),
      queue_(options.caller_runs) {}

absl::StatusOr<std::unique_ptr<RiskEngine>> RiskEngine::Create(const RiskEngineOptions& options) {
  if (options.cpu_workers < 0 || options.cpu_workers > 1024) {
    return absl::InvalidArgumentError("cpu_workers must be in [0, 1024]");
  }
  if (options.min_chunk_configs < 1 || options.max_chunk_configs < options.min_chunk_configs) {
    return absl::InvalidArgumentError(
        "chunk sizes: need 1 <= min_chunk_configs <= max_chunk_configs");
  }
  for (const std::string& endpoint : options.fpga_shims) {
    std::string host;
    int port = 0;
    if (absl::Status s = net::SplitHostPort(endpoint, &host, &port); !s.ok()) return s;
  }
  auto engine = std::unique_ptr<RiskEngine>(new RiskEngine(options));
  engine->queue_.AddCpuWorkers(options.cpu_workers);
  {
    absl::MutexLock lock(&engine->mu_);
    for (int i = 0; i < options.cpu_workers; ++i) {
      engine->cpu_stats_.push_back(CpuWorkerStats{absl::StrCat("cpu-", i)});
    }
  }
  for (int i = 0; i < options.cpu_workers; ++i) {
    engine->cpu_threads_.emplace_back([e = engine.get(), i] { e->CpuWorkerLoop(i); });
  }
  for (const std::string& endpoint : options.fpga_shims) {
    if (absl::Status s = engine->AddFpgaWorker(endpoint); !s.ok()) return s;
  }
  return engine;
}

RiskEngine::~RiskEngine() {
  RISKPLAN_DCHECK(evaluating_.load() == 0);
  queue_.Stop();
  for (std::thread& t : cpu_threads_) t.join();
  // Stopped outside mu_: a worker's Stop() may wait for a connection attempt
  // (up to the connect timeout), and Stats() must not wait with it.
  std::vector<std::unique_ptr<FpgaWorker>> fpga;
  {
    absl::MutexLock lock(&mu_);
    fpga.swap(fpga_);
  }
  fpga.clear();  // each stops and joins
}

absl::Status RiskEngine::AddFpgaWorker(const std::string& endpoint) {
  std::string host;
  int port = 0;
  if (absl::Status s = net::SplitHostPort(endpoint, &host, &port); !s.ok()) return s;
  absl::MutexLock lock(&mu_);
  for (const auto& w : fpga_) {
    if (w->endpoint() == endpoint) {
      return absl::AlreadyExistsError(absl::StrCat("FPGA worker ", endpoint, " exists"));
    }
  }
  fpga_.push_back(std::make_unique<FpgaWorker>(
      endpoint, options_.fpga, &queue_, &blobs_,
      options_.on_worker_event ? options_.on_worker_event : WorkerEventFn(&LogToStderr)));
  fpga_.back()->Start();
  return absl::OkStatus();
}

absl::Status RiskEngine::RemoveFpgaWorker(const std::string& endpoint) {
  std::unique_ptr<FpgaWorker> worker;
  {
    absl::MutexLock lock(&mu_);
    auto it = std::find_if(fpga_.begin(), fpga_.end(),
                           [&](const auto& w) { return w->endpoint() == endpoint; });
    if (it == fpga_.end()) {
      return absl::NotFoundError(absl::StrCat("no FPGA worker ", endpoint));
    }
    worker = std::move(*it);
    fpga_.erase(it);
  }
  // Outside mu_, as in the destructor.
  worker->Stop();  // its chunk in flight goes back to the queue
  return absl::OkStatus();
}

std::unique_ptr<CpuRiskKernel> RiskEngine::TakeKernel() {
  {
    absl::MutexLock lock(&mu_);
    if (!spare_kernels_.empty()) {
      std::unique_ptr<CpuRiskKernel> kernel = std::move(spare_kernels_.back());
      spare_kernels_.pop_back();
      return kernel;
    }
  }
  return std::make_unique<CpuRiskKernel>(&prepared_maps_, &site_cache_, options_.kernel,
                                         &kernel_weights_);
}

void RiskEngine::ReturnKernel(std::unique_ptr<CpuRiskKernel> kernel) {
  absl::MutexLock lock(&mu_);
  spare_kernels_.push_back(std::move(kernel));
}

void RiskEngine::CpuWorkerLoop(int index) {
  CpuRiskKernel kernel(&prepared_maps_, &site_cache_, options_.kernel, &kernel_weights_);
  while (true) {
    Chunk* chunk = queue_.Take(WorkQueue::Taker::kCpu, absl::Seconds(1));
    if (chunk == nullptr) {
      if (queue_.stopped()) return;
      continue;
    }
    const absl::Time start = absl::Now();
    kernel.Evaluate(*chunk->batch->model, chunk->configs(), chunk->out());
    const double seconds = absl::ToDoubleSeconds(absl::Now() - start);
    const size_t count = chunk->count;
    queue_.Complete(chunk);
    absl::MutexLock lock(&mu_);
    CpuWorkerStats& s = cpu_stats_[index];
    ++s.chunks;
    s.configurations += count;
    s.busy_seconds += seconds;
  }
}

absl::Status RiskEngine::Evaluate(const RiskModel& model, std::span<const Pose> configs,
                                  std::span<ConfigurationRisk> out, const StopCondition* stop) {
  if (out.size() != configs.size()) {
    return absl::InvalidArgumentError("RiskEngine::Evaluate: out and configs differ in size");
  }
  if (configs.size() > (size_t{1} << 32)) {
    return absl::InvalidArgumentError(
        "RiskEngine::Evaluate: batch of more than 2^32 configurations");
  }
  if (configs.empty()) return absl::OkStatus();
  evaluating_.fetch_add(1, std::memory_order_relaxed);
  struct Done {
    std::atomic<int>* count;
    ~Done() { count->fetch_sub(1, std::memory_order_relaxed); }
  } done{&evaluating_};
  const size_t n = configs.size();
  const size_t workers =
      std::max<size_t>(1, static_cast<size_t>(options_.cpu_workers + queue_.fpga_up() +
                                              (options_.caller_runs ? 1 : 0)));
  size_t chunk = std::clamp<size_t>((n + 2 * workers - 1) / (2 * workers),
                                    static_cast<size_t>(options_.min_chunk_configs),
                                    static_cast<size_t>(options_.max_chunk_configs));
  const size_t count = (n + chunk - 1) / chunk;
  chunk = (n + count - 1) / count;  // even chunks

  size_t caller_chunks = 0;
  size_t caller_configurations = 0;
  if (count == 1 && options_.caller_runs) {
    // The common case of the planners' small batches: no hand-over at all.
    std::unique_ptr<CpuRiskKernel> kernel = TakeKernel();
    kernel->Evaluate(model, configs, out);
    ReturnKernel(std::move(kernel));
    caller_chunks = 1;
    caller_configurations = n;
  } else {
    Batch batch;
    batch.model = &model;
    batch.configs = configs;
    batch.out = out;
    batch.remaining = count;
    std::vector<Chunk> chunks(count);
    for (size_t c = 0; c < count; ++c) {
      chunks[c].batch = &batch;
      chunks[c].first = c * chunk;
      chunks[c].count = std::min(chunk, n - c * chunk);
    }
    queue_.Submit(chunks);
    std::unique_ptr<CpuRiskKernel> kernel;
    caller_chunks = queue_.RunUntilDone(
        &batch,
        [&](Chunk* c) {
          if (kernel == nullptr) kernel = TakeKernel();
          kernel->Evaluate(model, c->configs(), c->out());
          caller_configurations += c->count;
        },
        stop);
    if (kernel != nullptr) ReturnKernel(std::move(kernel));
  }
  absl::MutexLock lock(&mu_);
  ++batches_;
  configurations_ += n;
  chunks_ += count;
  caller_chunks_ += caller_chunks;
  caller_configurations_ += caller_configurations;
  return absl::OkStatus();
}

std::unique_ptr<RiskEvaluator> RiskEngine::NewEvaluator(StopCondition stop) {
  return std::make_unique<EngineEvaluator>(this, stop);
}

RiskEngineStats RiskEngine::Stats() const {
  RiskEngineStats s;
  {
    absl::MutexLock lock(&mu_);
    s.batches = batches_;
    s.configurations = configurations_;
    s.chunks = chunks_;
    s.caller_chunks = caller_chunks_;
    s.caller_configurations = caller_configurations_;
    s.cpu = cpu_stats_;
    for (const auto& w : fpga_) s.fpga.push_back(w->Stats());
  }
  for (const FpgaWorkerStats& f : s.fpga) s.requeues += f.requeued;
  s.taken_over = queue_.taken_over();
  s.cache_hits = site_cache_.hits();
  s.cache_misses = site_cache_.misses();
  s.site_cache_bytes = site_cache_.capacity_bytes();
  s.prepared_map_bytes = prepared_maps_.MemoryBytes();
  s.blob_cache_bytes = blobs_.MemoryBytes();
  s.kernel_weights_bytes = kernel_weights_.MemoryBytes();
  s.site_cache_limit_bytes = options_.site_cache_bytes;
  s.prepared_map_limit_bytes = options_.prepared_map_bytes;
  s.blob_cache_limit_bytes = options_.blob_cache_bytes;
  s.kernel_weights_limit_bytes = options_.kernel_weights_bytes;
  return s;
}

}  // namespace riskplan::accel
