// FpgaWorker: a RiskEngine worker that evaluates chunks on one board through
// its riskplan-fpga-shim. It locates the configurations on the server (steps
// 1-3 of the spec), sends the kernel sites, gets the board's exact
// fixed-point EWMM sums, and finishes on the server (FromSums), as the
// thesis divides the work.
//
// States (every change is reported through the event callback and counted):
//   probing  connect, HELLO (protocol version, number format, limits), then
//            the known-answer batch; success -> up, failure -> down
//   up       takes chunks; pings the board when idle for ping_interval;
//            a failed request -> suspect (the chunk goes back to the queue),
//            or -> down once max_consecutive_failures chunks in a row have
//            failed
//   suspect  reconnects, HELLO and the known-answer batch again; success ->
//            up, failure -> down
//   down     waits a back-off (doubling from backoff_initial to backoff_max,
//            with jitter), then -> probing. The back-off starts again from
//            backoff_initial only when the board completes a chunk, so a
//            board that passes its checks but keeps failing real work is
//            tried ever less often (at most one failed chunk per
//            backoff_max).
// A request fails on a connection or deadline error, a corrupt frame, an
// ERROR reply, wrong scales, implausible sums, or sums that the spot check
// finds outside the format's error bound (accel/board_audit.h).
// A board that lacks a blob of the chunk's model gets the chunk given back
// (not a failure) and the blob uploaded with no chunk held.
// A chunk whose model the board cannot serve (kernel wider than the board's
// largest side, too many bins, blobs too large for its store or for the
// server's blob cache) goes back to the queue marked CPU-only, and the
// worker stays up.
// While the board works on a chunk, the chunk's caller may take it over
// (once its cancellation, deadline or time budget is reached: a stalled
// board must not hold a plan past them); the board's reply is then dropped,
// and only a failure of the request counts.
//
// Thread-safe: the worker runs on its own thread; Stats() and Stop() may be
// called from any thread.
#ifndef RISKPLAN_ACCEL_FPGA_WORKER_H_
#define RISKPLAN_ACCEL_FPGA_WORKER_H_

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <random>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/strings/string_view.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "accel/blobs.h"
#include "accel/board_audit.h"
#include "accel/cpu_kernel.h"
#include "accel/shim_client.h"
#include "accel/work_queue.h"

namespace riskplan::accel {

enum class WorkerState { kUp = 0, kSuspect = 1, kDown = 2, kProbing = 3 };
absl::string_view WorkerStateName(WorkerState state);  // "up", "suspect", ...

struct WorkerEvent {
  std::string worker;  // "fpga:HOST:PORT"
  WorkerState from = WorkerState::kProbing;
  WorkerState to = WorkerState::kProbing;
  std::string reason;
};
using WorkerEventFn = std::function<void(const WorkerEvent&)>;

struct FpgaWorkerOptions {
  ShimClientOptions client;
  absl::Duration backoff_initial = absl::Milliseconds(100);
  absl::Duration backoff_max = absl::Seconds(10);
  absl::Duration ping_interval = absl::Seconds(2);
  // A chunk that failed on FPGA workers this often is left to the CPU.
  int max_failures_per_chunk = 2;
  // Chunks failed in a row (none completed in between) after which the
  // worker goes down instead of suspect.
  int max_consecutive_failures = 2;
  // Sites of every EVAL reply recomputed on the CPU and compared within the
  // number format's error bound (0: no spot checks). Chosen at random.
  int audited_sites_per_eval = 2;
};

struct FpgaWorkerStats {
  std::string name;
  std::string endpoint;
  WorkerState state = WorkerState::kProbing;
  bool identified = false;
  HelloReply hello;  // valid when identified
  uint64_t chunks = 0;
  uint64_t configurations = 0;
  uint64_t failures = 0;     // failed requests (their chunks given back unless taken over)
  uint64_t unsupported = 0;  // chunks given back as CPU-only
  uint64_t requeued = 0;     // chunks given back (failed or unsupported, not taken over)
  // Chunks whose caller took them over while the board worked on them (its
  // stop was reached: a stalled or slow board); their replies are dropped.
  uint64_t taken_over = 0;
  uint64_t state_changes = 0;
  uint64_t audited = 0;         // sites spot-checked against the CPU
  uint64_t audit_failures = 0;  // replies refused by the spot check
  uint64_t uploads = 0;         // blobs uploaded
  uint64_t device_cycles = 0;   // as reported by the board
  double busy_seconds = 0.0;
  std::string last_error;
};

class FpgaWorker {
 public:
  // `queue`, `blobs` must outlive the worker.
  FpgaWorker(std::string endpoint, const FpgaWorkerOptions& options, WorkQueue* queue,
             BlobCache* blobs, WorkerEventFn on_event);
  ~FpgaWorker();  // Stop() and join

  void Start();
  // Interrupts the request in flight (its chunk goes back to the queue) and
  // ends the thread. Returns once the thread has ended; a connection attempt
  // in progress is waited for (at most the connect timeout).
  void Stop();

  const std::string& endpoint() const { return endpoint_; }
  FpgaWorkerStats Stats() const;

 private:
  void Run();
  // Connect, HELLO and the known-answer batch (probing and suspect).
  absl::Status Probe();
  absl::Status Connect();
  // Evaluates a chunk: locates its sites, asks the board (under a lease: the
  // chunk's caller may take it over meanwhile, WorkQueue::BeginIo), then
  // finishes and checks the replies into the chunk's results (a failed chunk
  // is given back and redone whole, so partial results are overwritten).
  // `unsupported` is set when the failure is the model's, not the board's;
  // `taken_over` when the caller took the chunk over during the requests
  // (then the chunk must not be touched again, whatever the status).
  // `missing` is set when the board lacks one of the model's blobs (then the
  // status is NotFound, and the worker gives the chunk back and uploads it).
  absl::Status RunChunk(Chunk* chunk, bool* unsupported, bool* taken_over,
                        std::shared_ptr<const Blob>* missing);

  // What a board's replies for a map must look like: the scales it must
  // report and the largest sums the quantised inputs allow.
  struct ReplyBounds {
    BoardScales scales;
    int impact_scale = 0;
    int shelter_scale = 0;
    double impact_max = 0.0;
    double shelter_max = 0.0;
  };
  static ReplyBounds BoundsFor(const NumberFormat& format, double max_density);

  // Run's steps, by state.
  // Probing and suspect: Probe(), then up (reason `passed`) or down (reason
  // `failed` and the error).
  void Recheck(absl::string_view passed, absl::string_view failed);
  // Down: waits the back-off, then probing.
  void BackOff();
  // Up: takes a chunk and runs it, or pings the board when none came within
  // ping_interval.
  void Serve();
  // What Serve does after RunChunk: the chunk given back and the missing
  // blob uploaded; the chunk completed; the chunk failed (given back, or
  // left to the CPU).
  void GiveBackAndUpload(Chunk* chunk, const Blob& missing, bool taken_over, double seconds);
  void Completed(Chunk* chunk, size_t count, bool taken_over, double seconds);
  void Failed(Chunk* chunk, const absl::Status& s, bool unsupported, bool taken_over,
              double seconds);
  // The board failed `s` (a request of `what`: "requests", "chunks"): drops
  // the connection, and goes suspect, or down after max_consecutive_failures
  // in a row.
  void BoardFailed(const absl::Status& s, absl::string_view what);

  // RunChunk's steps.
  // Locates the chunk's configurations into sites_ and device_sites_.
  void LocateSites(const RiskModel& model, Chunk& chunk);
  // OK when both blobs exist (nullptr: larger than the blob cache) and fit
  // the board's store; ResourceExhausted otherwise.
  absl::Status CheckBlobsFit(const Blob* map, const Blob* kernels, const HelloReply& hello) const;
  // Sends device_sites_ in EVALs of `step` sites, the replies into replies_;
  // sets `missing` when the board lacks one of the blobs.
  absl::Status AskBoard(const std::shared_ptr<const Blob>& map,
                        const std::shared_ptr<const Blob>& kernels, size_t step,
                        std::shared_ptr<const Blob>* missing);
  // Checks replies_ and writes their risks into `out`.
  absl::Status FinishSites(const RiskModel& model, double max_density, const HelloReply& hello,
                           std::span<ConfigurationRisk> out);
  // One reply's sums (sites first .. first + n - 1): scales and plausibility
  // checked, then finished into `out`.
  absl::Status StoreSums(const RiskModel& model, const EvalReply& reply, size_t first, size_t n,
                         const ReplyBounds& bounds, std::span<ConfigurationRisk> out) const;
  // Spot checks of one reply against the CPU (audited_sites_per_eval sites).
  absl::Status SpotCheck(const RiskModel& model, const EvalReply& reply, size_t first, size_t n,
                         const ReplyBounds& bounds);
  // Uploads a blob the board asked for, holding no chunk.
  absl::Status Upload(const Blob& blob);
  void SetState(WorkerState to, std::string reason);
  // Waits `duration` unless stopped first.
  void Sleep(absl::Duration duration);
  void DropClient();

  const std::string endpoint_;
  const std::string name_;
  const FpgaWorkerOptions options_;
  WorkQueue* const queue_;
  BlobCache* const blobs_;
  const WorkerEventFn on_event_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  // Worker-thread state.
  std::unique_ptr<ShimClient> owned_client_;
  std::vector<LocatedSite> sites_;
  std::vector<DeviceSite> device_sites_;
  std::vector<EvalReply> replies_;
  WorkQueue::Lease lease_;
  absl::Duration backoff_;
  int consecutive_failures_ = 0;
  int uploads_since_chunk_ = 0;
  std::mt19937_64 rng_;  // jitter and the sites to spot-check

  mutable absl::Mutex mu_;
  absl::CondVar stop_changed_;
  ShimClient* client_ ABSL_GUARDED_BY(mu_) = nullptr;  // for Stop() to interrupt
  FpgaWorkerStats stats_ ABSL_GUARDED_BY(mu_);
};

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_FPGA_WORKER_H_
