#include "accel/fpga_worker.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "accel/board_audit.h"
#include "accel/known_answer.h"

namespace riskplan::accel {

namespace {

// OK when the board takes the model's kernels (FailedPrecondition otherwise).
absl::Status CheckKernelsFit(const ImpactTable& table, const HelloReply& hello) {
  const int widest = 2 * table.bin(table.height_bins()).half_width + 1;
  // The protocol carries a site's bins as u16 (DeviceSite).
  if (widest > static_cast<int>(hello.max_kernel_side) || table.height_bins() > 65535 ||
      table.heading_bins() > 65535) {
    return absl::FailedPreconditionError(
        absl::StrFormat("the board takes kernels up to %d cells wide; this model needs %d",
                        hello.max_kernel_side, widest));
  }
  return absl::OkStatus();
}

}  // namespace

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
      case WorkerState::kProbing:
        Recheck("handshake and known-answer batch passed", "probe failed: ");
        break;
      case WorkerState::kDown:
        BackOff();
        break;
      case WorkerState::kSuspect:
        Recheck("reconnected, handshake and known-answer batch passed", "recheck failed: ");
        break;
      case WorkerState::kUp:
        Serve();
        break;
    }
  }
  DropClient();
  // A stopped worker is no longer up (the queue's count must not keep it).
  SetState(WorkerState::kDown, "stopped");
}

void FpgaWorker::Recheck(absl::string_view passed, absl::string_view failed) {
  absl::Status s = Probe();
  // Stopped meanwhile: the probe's result says nothing of the board.
  if (stop_.load()) return;
  if (s.ok()) {
    SetState(WorkerState::kUp, std::string(passed));
  } else {
    DropClient();
    SetState(WorkerState::kDown, absl::StrCat(failed, s.message()));
  }
}

void FpgaWorker::BackOff() {
  // Back-off with +-20 % jitter so that boards restarted together are
  // not all probed at once.
  const double factor = 0.8 + 0.4 * std::uniform_real_distribution<double>()(rng_);
  Sleep(backoff_ * factor);
  backoff_ = std::min(backoff_ * 2, options_.backoff_max);
  if (!stop_.load()) SetState(WorkerState::kProbing, "back-off elapsed");
}

void FpgaWorker::Serve() {
  Chunk* chunk = queue_->Take(WorkQueue::Taker::kFpga, options_.ping_interval, &stop_);
  if (chunk == nullptr) {
    if (stop_.load() || queue_->stopped()) return;
    if (absl::Status s = owned_client_->Ping(); !s.ok()) {
      DropClient();
      SetState(WorkerState::kSuspect, absl::StrCat("idle ping failed: ", s.message()));
    }
    return;
  }
  const absl::Time start = absl::Now();
  const size_t count = chunk->count;
  bool unsupported = false;
  bool taken_over = false;
  std::shared_ptr<const Blob> missing;
  absl::Status s = RunChunk(chunk, &unsupported, &taken_over, &missing);
  const double seconds = absl::ToDoubleSeconds(absl::Now() - start);
  if (missing != nullptr) {
    GiveBackAndUpload(chunk, *missing, taken_over, seconds);
  } else if (s.ok()) {
    Completed(chunk, count, taken_over, seconds);
  } else {
    Failed(chunk, s, unsupported, taken_over, seconds);
  }
}

void FpgaWorker::GiveBackAndUpload(Chunk* chunk, const Blob& missing, bool taken_over,
                                   double seconds) {
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
  absl::Status s = Upload(missing);
  if (s.ok()) return;
  {
    absl::MutexLock lock(&mu_);
    ++stats_.failures;
    stats_.last_error = std::string(s.message());
  }
  BoardFailed(s, "requests");
}

void FpgaWorker::Completed(Chunk* chunk, size_t count, bool taken_over, double seconds) {
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
}

void FpgaWorker::Failed(Chunk* chunk, const absl::Status& s, bool unsupported, bool taken_over,
                        double seconds) {
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
  // A model the board cannot serve is no fault of the board: it stays up.
  if (!unsupported) BoardFailed(s, "chunks");
}

void FpgaWorker::BoardFailed(const absl::Status& s, absl::string_view what) {
  DropClient();
  if (stop_.load()) return;
  if (++consecutive_failures_ >= options_.max_consecutive_failures) {
    SetState(WorkerState::kDown, absl::StrFormat("%d %s failed in a row, the last: %s",
                                                 consecutive_failures_, what, s.message()));
  } else {
    SetState(WorkerState::kSuspect, std::string(s.message()));
  }
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
  const HelloReply& hello = owned_client_->hello();
  *taken_over = false;
  if (absl::Status s = CheckKernelsFit(model.table(), hello); !s.ok()) {
    *unsupported = true;
    return s;
  }
  *unsupported = false;

  // Before the board is asked: everything the requests need, in this
  // worker's own memory (the chunk may be taken over while they run; the
  // map and table are shared, they outlive it).
  const std::shared_ptr<const RiskMap> map_ptr = model.map_ptr();
  const std::shared_ptr<const ImpactTable> table_ptr = model.table_ptr();
  LocateSites(model, *chunk);

  // The board's time: building the blobs (the first time, about a second
  // for a large map) and the requests (uploads included) touch no chunk
  // memory, and a caller whose stop is reached may take the chunk over
  // meanwhile.
  queue_->BeginIo(&lease_, chunk);
  std::shared_ptr<const Blob> map = blobs_->MapBlob(map_ptr);
  std::shared_ptr<const Blob> kernels = blobs_->KernelsBlob(table_ptr);
  absl::Status io = CheckBlobsFit(map.get(), kernels.get(), hello);
  if (!io.ok()) {
    *unsupported = true;
  } else {
    io = AskBoard(map, kernels, hello.max_sites_per_eval, missing);
  }
  if (!queue_->EndIo(&lease_)) {
    // Taken over: the chunk is the caller's (and may be gone). A failed
    // request is still the board's failure, a missing blob still uploaded; a
    // good reply is dropped.
    *taken_over = true;
    return io;
  }
  if (!io.ok()) return io;
  return FinishSites(model, map->max_density, hello, chunk->out());
}

void FpgaWorker::LocateSites(const RiskModel& model, Chunk& chunk) {
  sites_.clear();
  CpuRiskKernel::LocateBatch(model, chunk.configs(), chunk.out(), &sites_);
  device_sites_.resize(sites_.size());
  for (size_t a = 0; a < sites_.size(); ++a) {
    const KernelSite& s = sites_[a].site;
    device_sites_[a] = DeviceSite{static_cast<uint16_t>(s.height_bin),
                                  static_cast<uint16_t>(s.heading_bin), s.impact_i, s.impact_j};
  }
}

absl::Status FpgaWorker::CheckBlobsFit(const Blob* map, const Blob* kernels,
                                       const HelloReply& hello) const {
  if (map == nullptr || kernels == nullptr) {
    return absl::ResourceExhaustedError(
        absl::StrFormat("the model's %s blob is larger than the blob cache (%d bytes)",
                        map == nullptr ? "map" : "kernels", blobs_->budget_bytes()));
  }
  if (map->bytes.size() > hello.store_bytes || kernels->bytes.size() > hello.store_bytes) {
    return absl::ResourceExhaustedError("the model's blobs exceed the board's store");
  }
  return absl::OkStatus();
}

absl::Status FpgaWorker::AskBoard(const std::shared_ptr<const Blob>& map,
                                  const std::shared_ptr<const Blob>& kernels, size_t step,
                                  std::shared_ptr<const Blob>* missing) {
  replies_.clear();
  for (size_t first = 0; first < sites_.size(); first += step) {
    const size_t n = std::min(step, sites_.size() - first);
    absl::StatusOr<EvalReply> reply = owned_client_->Eval(
        map->hash, kernels->hash, std::span<const DeviceSite>(device_sites_).subspan(first, n));
    if (absl::IsNotFound(reply.status())) {
      const BlobHash wanted = owned_client_->missing_blob();
      *missing = wanted == map->hash ? map : wanted == kernels->hash ? kernels : nullptr;
      return *missing != nullptr ? reply.status()
                                 : absl::DataLossError(absl::StrCat(
                                       "shim ", endpoint_, " asked for a blob that was not named"));
    }
    if (!reply.ok()) return reply.status();
    replies_.push_back(*std::move(reply));
  }
  return absl::OkStatus();
}

FpgaWorker::ReplyBounds FpgaWorker::BoundsFor(const NumberFormat& format, double max_density) {
  ReplyBounds b;
  // The scales the board must report (its exponent rule is part of the
  // format; the shelter layer's largest value is 10, the out-of-map value),
  // and the largest sums the quantised inputs allow, (1 + 4096 * 2^-W) * max
  // * (1 + 2^(2-M)) (docs/shim-protocol.md, "EVAL and EVAL_REPLY").
  b.scales = BoardScales{format, LayerExponent(max_density, format.cell_bits),
                         LayerExponent(10.0, format.cell_bits)};
  b.impact_scale = format.weight_frac_bits + b.scales.density_exponent;
  b.shelter_scale = format.weight_frac_bits + b.scales.shelter_exponent;
  const double weight_sum_max = 1.0 + kMaxWindowCells * std::ldexp(1.0, -format.weight_frac_bits);
  const double margin = 1.0 + std::ldexp(1.0, 2 - format.cell_bits);
  b.impact_max = weight_sum_max * max_density * margin;
  b.shelter_max = weight_sum_max * 10.0 * margin;
  return b;
}

absl::Status FpgaWorker::FinishSites(const RiskModel& model, double max_density,
                                     const HelloReply& hello, std::span<ConfigurationRisk> out) {
  const ReplyBounds bounds = BoundsFor(hello.format, max_density);
  const size_t step = hello.max_sites_per_eval;
  uint64_t cycles = 0;
  for (size_t r = 0; r < replies_.size(); ++r) {
    const EvalReply& reply = replies_[r];
    const size_t first = r * step;
    const size_t n = std::min(step, sites_.size() - first);
    if (absl::Status s = StoreSums(model, reply, first, n, bounds, out); !s.ok()) return s;
    if (absl::Status s = SpotCheck(model, reply, first, n, bounds); !s.ok()) return s;
    cycles += reply.device_cycles;
  }
  absl::MutexLock lock(&mu_);
  stats_.device_cycles += cycles;
  return absl::OkStatus();
}

absl::Status FpgaWorker::StoreSums(const RiskModel& model, const EvalReply& reply, size_t first,
                                   size_t n, const ReplyBounds& bounds,
                                   std::span<ConfigurationRisk> out) const {
  if (reply.impact_scale != bounds.impact_scale || reply.shelter_scale != bounds.shelter_scale) {
    return absl::DataLossError(absl::StrFormat("shim %s: result scales %d/%d, expected %d/%d",
                                               endpoint_, reply.impact_scale, reply.shelter_scale,
                                               bounds.impact_scale, bounds.shelter_scale));
  }
  for (size_t a = 0; a < n; ++a) {
    const double impact = AccumulatorToDouble(reply.impact[a], bounds.impact_scale);
    const double shelter = AccumulatorToDouble(reply.shelter[a], bounds.shelter_scale);
    // Written so that a NaN is refused too.
    if (!(impact <= bounds.impact_max) || !(shelter <= bounds.shelter_max)) {
      return absl::DataLossError(
          absl::StrFormat("shim %s: implausible sums I = %g, S = %g (largest possible %g, %g)",
                          endpoint_, impact, shelter, bounds.impact_max, bounds.shelter_max));
    }
    const LocatedSite& s = sites_[first + a];
    out[s.index] = model.FromSums(s.site, impact, shelter);
  }
  return absl::OkStatus();
}

absl::Status FpgaWorker::SpotCheck(const RiskModel& model, const EvalReply& reply, size_t first,
                                   size_t n, const ReplyBounds& bounds) {
  // A few sites recomputed on the CPU (the reply is refused whole when one
  // is off).
  const int audits = static_cast<int>(std::min<size_t>(options_.audited_sites_per_eval, n));
  for (int k = 0; k < audits; ++k) {
    const size_t a = std::uniform_int_distribution<size_t>(0, n - 1)(rng_);
    absl::Status audit =
        AuditBoardSums(model, sites_[first + a].site, bounds.scales,
                       AccumulatorToDouble(reply.impact[a], bounds.impact_scale),
                       AccumulatorToDouble(reply.shelter[a], bounds.shelter_scale));
    if (!audit.ok()) {
      absl::MutexLock lock(&mu_);
      stats_.audited += k + 1;
      ++stats_.audit_failures;
      return absl::DataLossError(
          absl::StrCat("shim ", endpoint_, " failed a spot check: ", audit.message()));
    }
  }
  absl::MutexLock lock(&mu_);
  stats_.audited += audits;
  return absl::OkStatus();
}

}  // namespace riskplan::accel
