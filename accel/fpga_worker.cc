#include "accel/fpga_worker.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "accel/board_audit.h"
#include "accel/known_answer.h"

namespace riskplan::accel {

absl::string_view WorkerStateName(WorkerState state) {
  switch (state) {
    case WorkerState::kUp:
      return "up";
    case WorkerState::kSuspect:
      return "suspect";
    case WorkerState::kDown:
      return "down";
    case WorkerState::kProbing:
      return "probing";
  }
  return "unknown";
}

FpgaWorker::FpgaWorker(std::string endpoint, const FpgaWorkerOptions& options, WorkQueue* queue,
                       BlobCache* blobs, WorkerEventFn on_event)
    : endpoint_(std::move(endpoint)),
      name_(absl::StrCat("fpga:", endpoint_)),
      options_(options),
      queue_(queue),
      blobs_(blobs),
      on_event_(std::move(on_event)),
      backoff_(options.backoff_initial),
      rng_(std::hash<std::string>()(endpoint_)) {
  stats_.name = name_;
  stats_.endpoint = endpoint_;
  stats_.state = WorkerState::kProbing;
}

FpgaWorker::~FpgaWorker() { Stop(); }

void FpgaWorker::Start() {
  thread_ = std::thread([this] { Run(); });
}

void FpgaWorker::Stop() {
  {
    absl::MutexLock lock(&mu_);
    stop_.store(true);
    if (client_ != nullptr) client_->Interrupt();
    stop_changed_.SignalAll();
  }
  queue_->Wake();
  if (thread_.joinable()) thread_.join();
}

FpgaWorkerStats FpgaWorker::Stats() const {
  absl::MutexLock lock(&mu_);
  return stats_;
}

void FpgaWorker::SetState(WorkerState to, std::string reason) {
  WorkerEvent event;
  {
    absl::MutexLock lock(&mu_);
    if (stats_.state == to) return;
    event = WorkerEvent{name_, stats_.state, to, std::move(reason)};
    stats_.state = to;
    ++stats_.state_changes;
    // Going down or suspect is what an operator wants to know the reason of
    // (probing only says the back-off elapsed).
    if ((to == WorkerState::kDown || to == WorkerState::kSuspect) && !event.reason.empty()) {
      stats_.last_error = event.reason;
    }
  }
  // The queue counts the workers that are up: callers without CPU workers
  // fall back to running chunks themselves when none is.
  if (to == WorkerState::kUp) queue_->FpgaUpChanged(+1);
  if (event.from == WorkerState::kUp) queue_->FpgaUpChanged(-1);
  if (on_event_) on_event_(event);
}

void FpgaWorker::Sleep(absl::Duration duration) {
  const absl::Time deadline = absl::Now() + duration;
  absl::MutexLock lock(&mu_);
  while (!stop_.load()) {
    if (stop_changed_.WaitWithDeadline(&mu_, deadline)) return;
  }
}

void FpgaWorker::DropClient() {
  {
    absl::MutexLock lock(&mu_);
    client_ = nullptr;
  }
  owned_client_.reset();
}

absl::Status FpgaWorker::Connect() {
  DropClient();
  absl::StatusOr<std::unique_ptr<ShimClient>> client =
      ShimClient::Connect(endpoint_, options_.client);
  if (!client.ok()) return client.status();
  owned_client_ = *std::move(client);
  uploads_since_chunk_ = 0;
  absl::MutexLock lock(&mu_);
  if (stop_.load()) owned_client_->Interrupt();
  client_ = owned_client_.get();
  stats_.identified = true;
  stats_.hello = owned_client_->hello();
  return absl::OkStatus();
}

absl::Status FpgaWorker::Probe() {
  if (absl::Status s = Connect(); !s.ok()) return s;
  return RunKnownAnswer(*owned_client_);
}

void FpgaWorker::Run() {
  while (!stop_.load()) {
    WorkerState state;
    {
      absl::MutexLock lock(&mu_);
      state = stats_.state;
    }
    switch (state) {
      case WorkerState::kProbing: {
        absl::Status s = Probe();
        if (stop_.load()) break;
        if (s.ok()) {
          SetState(WorkerState::kUp, "handshake and known-answer batch passed");
        } else {
          DropClient();
          SetState(WorkerState::kDown, absl::StrCat("probe failed: ", s.message()));
        }
        break;
      }
      case WorkerState::kDown: {
        // Back-off with +-20 % jitter so that boards restarted together are
        // not all probed at once.
        const double factor = 0.8 + 0.4 * std::uniform_real_distribution<double>()(rng_);
        Sleep(backoff_ * factor);
        backoff_ = std::min(backoff_ * 2, options_.backoff_max);
        if (!stop_.load()) SetState(WorkerState::kProbing, "back-off elapsed");
        break;
      }
      case WorkerState::kSuspect: {
        absl::Status s = Probe();
        if (stop_.load()) break;
        if (s.ok()) {
          SetState(WorkerState::kUp, "reconnected, handshake and known-answer batch passed");
        } else {
          DropClient();
          SetState(WorkerState::kDown, absl::StrCat("recheck failed: ", s.message()));
        }
        break;
      }
      case WorkerState::kUp: {
        Chunk* chunk = queue_->Take(WorkQueue::Taker::kFpga, options_.ping_interval, &stop_);
        if (chunk == nullptr) {
          if (stop_.load() || queue_->stopped()) break;
          if (absl::Status s = owned_client_->Ping(); !s.ok()) {
            DropClient();
            SetState(WorkerState::kSuspect, absl::StrCat("idle ping failed: ", s.message()));
          }
          break;
        }
        const absl::Time start = absl::Now();
        const size_t count = chunk->count;
        bool unsupported = false;
        bool taken_over = false;
        std::shared_ptr<const Blob> missing;
        absl::Status s = RunChunk(chunk, &unsupported, &taken_over, &missing);
        const double seconds = absl::ToDoubleSeconds(absl::Now() - start);
        if (missing != nullptr) {
          // The board lacks a blob (it restarted, or dropped it): not its
          // failure. The chunk goes back at once, for the CPU or another
          // board, and the blob is uploaded with no chunk held (seconds for a
          // large map), so that no caller waits for the upload.
          {
            absl::MutexLock lock(&mu_);
            stats_.busy_seconds += seconds;
            ++(taken_over ? stats_.taken_over : stats_.requeued);
          }
          if (!taken_over) queue_->Requeue(chunk);
          s = Upload(*missing);
          if (s.ok()) break;
          {
            absl::MutexLock lock(&mu_);
            ++stats_.failures;
            stats_.last_error = std::string(s.message());
          }
          DropClient();
          if (stop_.load()) break;
          if (++consecutive_failures_ >= options_.max_consecutive_failures) {
            SetState(WorkerState::kDown,
                     absl::StrFormat("%d requests failed in a row, the last: %s",
                                     consecutive_failures_, s.message()));
          } else {
            SetState(WorkerState::kSuspect, std::string(s.message()));
          }
          break;
        }
        if (s.ok()) {
          // The board answered well (whether or not its caller still wanted it).
          consecutive_failures_ = 0;
          uploads_since_chunk_ = 0;
          backoff_ = options_.backoff_initial;
          {
            absl::MutexLock lock(&mu_);
            if (taken_over) {
              ++stats_.taken_over;
            } else {
              ++stats_.chunks;
              stats_.configurations += count;
            }
            stats_.busy_seconds += seconds;
          }
          if (!taken_over) queue_->Complete(chunk);
          break;
        }
        {
          absl::MutexLock lock(&mu_);
          stats_.busy_seconds += seconds;
          ++(unsupported ? stats_.unsupported : stats_.failures);
          if (taken_over) ++stats_.taken_over;
          stats_.last_error = std::string(s.message());
        }
        // A chunk taken over is its caller's now: it is neither counted nor given back.
        if (!taken_over) {
          if (unsupported || ++chunk->fpga_failures >= options_.max_failures_per_chunk) {
            chunk->cpu_only = true;
          }
          {
            absl::MutexLock lock(&mu_);
            ++stats_.requeued;
          }
          queue_->Requeue(chunk);
        }
        if (!unsupported) {
          DropClient();
          if (stop_.load()) break;
          if (++consecutive_failures_ >= options_.max_consecutive_failures) {
            SetState(WorkerState::kDown, absl::StrFormat("%d chunks failed in a row, the last: %s",
                                                         consecutive_failures_, s.message()));
          } else {
            SetState(WorkerState::kSuspect, std::string(s.message()));
          }
        }
        break;
      }
    }
  }
  DropClient();
  // A stopped worker is no longer up (the queue's count must not keep it).
  SetState(WorkerState::kDown, "stopped");
}

absl::Status FpgaWorker::Upload(const Blob& blob) {
  // A board that asks again and again (its store too small for a model's
  // blobs, say) without completing a chunk is failing, not missing a blob.
  if (uploads_since_chunk_ >= 2) {
    return absl::DataLossError(
        absl::StrFormat("shim %s asked for a blob again after %d uploads without a completed chunk",
                        endpoint_, uploads_since_chunk_));
  }
  if (absl::Status s = owned_client_->PutBlob(blob.kind, blob.hash, blob.bytes); !s.ok()) {
    return s;
  }
  ++uploads_since_chunk_;
  absl::MutexLock lock(&mu_);
  ++stats_.uploads;
  return absl::OkStatus();
}

absl::Status FpgaWorker::RunChunk(Chunk* chunk, bool* unsupported, bool* taken_over,
                                  std::shared_ptr<const Blob>* missing) {
  const RiskModel& model = *chunk->batch->model;
  const ImpactTable& table = model.table();
  const HelloReply& hello = owned_client_->hello();
  *unsupported = true;
  *taken_over = false;
  const int widest = 2 * table.bin(table.height_bins()).half_width + 1;
  if (widest > static_cast<int>(hello.max_kernel_side) || table.height_bins() > 65535 ||
      table.heading_bins() > 65535) {
    return absl::FailedPreconditionError(
        absl::StrFormat("the board takes kernels up to %d cells wide; this model needs %d",
                        hello.max_kernel_side, widest));
  }
  *unsupported = false;

  // Before the board is asked: everything the requests need, in this
  // worker's own memory (the chunk may be taken over while they run; the
  // map and table are shared, they outlive it).
  const std::shared_ptr<const RiskMap> map_ptr = model.map_ptr();
  const std::shared_ptr<const ImpactTable> table_ptr = model.table_ptr();
  sites_.clear();
  CpuRiskKernel::LocateBatch(model, chunk->configs(), chunk->out(), &sites_);
  device_sites_.resize(sites_.size());
  for (size_t a = 0; a < sites_.size(); ++a) {
    const KernelSite& s = sites_[a].site;
    device_sites_[a] = DeviceSite{static_cast<uint16_t>(s.height_bin),
                                  static_cast<uint16_t>(s.heading_bin), s.impact_i, s.impact_j};
  }
  const size_t step = hello.max_sites_per_eval;
  replies_.clear();

  // The board's time: building the blobs (the first time, about a second
  // for a large map) and the requests (uploads included) touch no chunk
  // memory, and a caller whose stop is reached may take the chunk over
  // meanwhile.
  queue_->BeginIo(&lease_, chunk);
  absl::Status io = absl::OkStatus();
  std::shared_ptr<const Blob> map = blobs_->MapBlob(map_ptr);
  std::shared_ptr<const Blob> kernels = blobs_->KernelsBlob(table_ptr);
  if (map == nullptr || kernels == nullptr) {
    *unsupported = true;
    io = absl::ResourceExhaustedError(
        absl::StrFormat("the model's %s blob is larger than the blob cache (%d bytes)",
                        map == nullptr ? "map" : "kernels", blobs_->budget_bytes()));
  } else if (map->bytes.size() > hello.store_bytes || kernels->bytes.size() > hello.store_bytes) {
    *unsupported = true;
    io = absl::ResourceExhaustedError("the model's blobs exceed the board's store");
  }
  for (size_t first = 0; io.ok() && first < sites_.size(); first += step) {
    const size_t n = std::min(step, sites_.size() - first);
    absl::StatusOr<EvalReply> reply = owned_client_->Eval(
        map->hash, kernels->hash, std::span<const DeviceSite>(device_sites_).subspan(first, n));
    if (absl::IsNotFound(reply.status())) {
      const BlobHash wanted = owned_client_->missing_blob();
      *missing = wanted == map->hash ? map : wanted == kernels->hash ? kernels : nullptr;
      io = *missing != nullptr ? reply.status()
                               : absl::DataLossError(absl::StrCat(
                                     "shim ", endpoint_, " asked for a blob that was not named"));
      break;
    }
    if (!reply.ok()) {
      io = reply.status();
      break;
    }
    replies_.push_back(*std::move(reply));
  }
  if (!queue_->EndIo(&lease_)) {
    // Taken over: the chunk is the caller's (and may be gone). A failed
    // request is still the board's failure, a missing blob still uploaded; a
    // good reply is dropped.
    *taken_over = true;
    return io;
  }
  if (!io.ok()) return io;

  const NumberFormat& format = hello.format;
  // The scales the board must report (its exponent rule is part of the
  // format), and the largest sums the quantised inputs allow.
  const BoardScales scales{format, LayerExponent(map->max_density, format.cell_bits),
                           LayerExponent(10.0, format.cell_bits)};
  const int impact_scale = format.weight_frac_bits + scales.density_exponent;
  const int shelter_scale = format.weight_frac_bits + scales.shelter_exponent;
  const double weight_sum_max = 1.0 + kMaxWindowCells * std::ldexp(1.0, -format.weight_frac_bits);
  const double margin = 1.0 + std::ldexp(1.0, 2 - format.cell_bits);
  const double impact_max = weight_sum_max * map->max_density * margin;
  const double shelter_max = weight_sum_max * 10.0 * margin;
  std::span<ConfigurationRisk> out = chunk->out();
  uint64_t cycles = 0;
  for (size_t r = 0; r < replies_.size(); ++r) {
    const EvalReply& reply = replies_[r];
    const size_t first = r * step;
    const size_t n = std::min(step, sites_.size() - first);
    if (reply.impact_scale != impact_scale || reply.shelter_scale != shelter_scale) {
      return absl::DataLossError(absl::StrFormat("shim %s: result scales %d/%d, expected %d/%d",
                                                 endpoint_, reply.impact_scale, reply.shelter_scale,
                                                 impact_scale, shelter_scale));
    }
    for (size_t a = 0; a < n; ++a) {
      const double impact = AccumulatorToDouble(reply.impact[a], impact_scale);
      const double shelter = AccumulatorToDouble(reply.shelter[a], shelter_scale);
      if (!(impact <= impact_max) || !(shelter <= shelter_max)) {
        return absl::DataLossError(
            absl::StrFormat("shim %s: implausible sums I = %g, S = %g (largest possible %g, %g)",
                            endpoint_, impact, shelter, impact_max, shelter_max));
      }
      const LocatedSite& s = sites_[first + a];
      out[s.index] = model.FromSums(s.site, impact, shelter);
    }
    // Spot checks: a few sites recomputed on the CPU (the reply is refused
    // whole when one is off).
    const int audits = static_cast<int>(std::min<size_t>(options_.audited_sites_per_eval, n));
    for (int k = 0; k < audits; ++k) {
      const size_t a = std::uniform_int_distribution<size_t>(0, n - 1)(rng_);
      absl::Status audit = AuditBoardSums(model, sites_[first + a].site, scales,
                                          AccumulatorToDouble(reply.impact[a], impact_scale),
                                          AccumulatorToDouble(reply.shelter[a], shelter_scale));
      if (!audit.ok()) {
        absl::MutexLock lock(&mu_);
        stats_.audited += k + 1;
        ++stats_.audit_failures;
        return absl::DataLossError(
            absl::StrCat("shim ", endpoint_, " failed a spot check: ", audit.message()));
      }
    }
    {
      absl::MutexLock lock(&mu_);
      stats_.audited += audits;
    }
    cycles += reply.device_cycles;
  }
  absl::MutexLock lock(&mu_);
  stats_.device_cycles += cycles;
  return absl::OkStatus();
}

}  // namespace riskplan::accel
