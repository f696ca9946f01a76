#include "client/load/load_generator.h"

#include <algorithm>
#include <atomic>
#include <cassert>
#include <cmath>
#include <thread>
#include <utility>

#include "absl/base/thread_annotations.h"
#include "absl/strings/str_format.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/clock.h"
#include "client/client.h"
#include "nlohmann/json.hpp"

namespace riskplan::client {
namespace {

// The shared state of one load phase. Every call goes through one channel
// and one stub (both thread-safe), as a real client process would: the run
// measures the server, not the cost of opening connections.
class LoadRun {
 public:
  LoadRun(std::shared_ptr<grpc::Channel> channel, const LoadOptions& options)
      : channel_(std::move(channel)), stub_(v1::Planner::NewStub(channel_)), options_(options) {
    report_.options = options;
  }

  LoadReport Run(const LoadProgressCallback& progress);

 private:
  template <typename Update>
  class StreamReactor;

  // Sends one call; `intended` is when it should have been sent.
  void IssueAsync(absl::Time intended);
  // One blocking call (closed loop).
  void CallSync(absl::Time intended);
  // Reads a blocking call's stream to its end, recording the first update and
  // counting them all; the call's status.
  template <typename Update>
  grpc::Status ReadStream(grpc::ClientReader<Update>& reader, absl::Time intended)
      ABSL_LOCKS_EXCLUDED(mu_);
  // `context`: the call's, whose peer names the replica that answered.
  void Record(absl::Time intended, const grpc::Status& status, absl::Time done,
              const grpc::ClientContext& context) ABSL_LOCKS_EXCLUDED(mu_);
  void RecordFirstUpdate(absl::Time intended, absl::Time at) ABSL_LOCKS_EXCLUDED(mu_);
  void RecordOverloaded() ABSL_LOCKS_EXCLUDED(mu_);
  void SendOpenLoop();
  void ReportProgress(const LoadProgressCallback& progress);

  const std::shared_ptr<grpc::Channel> channel_;
  const std::unique_ptr<v1::Planner::Stub> stub_;
  // A copy held for the whole run: the asynchronous calls read their request
  // through a pointer into it until they complete.
  const LoadOptions options_;
  absl::Time start_;
  absl::Time stop_;  // no call is sent from then on
  std::atomic<bool> finished_{false};

  absl::Mutex mu_;
  LoadReport report_ ABSL_GUARDED_BY(mu_);
  LatencyHistogram interval_ ABSL_GUARDED_BY(mu_);
  int64_t outstanding_ ABSL_GUARDED_BY(mu_) = 0;
  absl::Time last_done_ ABSL_GUARDED_BY(mu_);
};

// One streaming call (PlanTrajectory, PlanFleet), callback API. It owns
// itself: gRPC calls OnDone last, after every other reaction, so that is
// where it is deleted. The run outlives it, since Run waits until no call is
// outstanding.
template <typename Update>
class LoadRun::StreamReactor final : public grpc::ClientReadReactor<Update> {
 public:
  // `start(context, reactor)` begins the call (stub->async()->Method(...)).
  template <typename Start>
  StreamReactor(LoadRun* run, absl::Time intended, Start start) : run_(run), intended_(intended) {
    SetTimeout(&context_, run->options_.timeout);
    start(&context_, this);
    // The first read is queued before the call starts, so no message can
    // arrive without a read waiting for it.
    this->StartRead(&update_);
    this->StartCall();
  }
  void OnReadDone(bool ok) override {
    // !ok: the stream has ended; OnDone follows with the status.
    if (!ok) return;
    if (updates_++ == 0) run_->RecordFirstUpdate(intended_, absl::Now());
    this->StartRead(&update_);
  }
  void OnDone(const grpc::Status& status) override {
    {
      absl::MutexLock lock(&run_->mu_);
      run_->report_.plan_updates += updates_;
    }
    run_->Record(intended_, status, absl::Now(), context_);
    delete this;
  }

 private:
  LoadRun* const run_;
  const absl::Time intended_;
  grpc::ClientContext context_;
  Update update_;
  int64_t updates_ = 0;
};

void LoadRun::IssueAsync(absl::Time intended) {
  {
    absl::MutexLock lock(&mu_);
    ++report_.sent;
    ++outstanding_;
  }
  switch (options_.rpc) {
    case LoadRpc::kPlanTrajectory:
      new StreamReactor<v1::PlanUpdate>(
          this, intended,
          [this](grpc::ClientContext* context, grpc::ClientReadReactor<v1::PlanUpdate>* reactor) {
            stub_->async()->PlanTrajectory(context, &options_.plan_request, reactor);
          });
      return;
    case LoadRpc::kPlanFleet:
      new StreamReactor<v1::FleetUpdate>(
          this, intended,
          [this](grpc::ClientContext* context, grpc::ClientReadReactor<v1::FleetUpdate>* reactor) {
            stub_->async()->PlanFleet(context, &options_.fleet_request, reactor);
          });
      return;
    case LoadRpc::kEvaluateRisk: {
      // The callback API needs the context and the response to live until
      // the callback runs, which is after this function returns: they are
      // allocated here and freed by the callback, their last user.
      auto* context = new grpc::ClientContext;
      auto* response = new v1::EvaluateRiskResponse;
      SetTimeout(context, options_.timeout);
      stub_->async()->EvaluateRisk(context, &options_.eval_request, response,
                                   [this, context, response, intended](grpc::Status status) {
                                     Record(intended, status, absl::Now(), *context);
                                     delete response;
                                     delete context;
                                   });
      return;
    }
    case LoadRpc::kConnect:  // closed loop only (RunLoad's caller checks)
    case LoadRpc::kPing: {
      auto* context = new grpc::ClientContext;
      auto* response = new v1::PingResponse;
      SetTimeout(context, options_.timeout);
      static const v1::PingRequest kPing;  // outlives every call
      stub_->async()->Ping(context, &kPing, response,
                           [this, context, response, intended](grpc::Status status) {
                             Record(intended, status, absl::Now(), *context);
                             delete response;
                             delete context;
                           });
      return;
    }
  }
}

template <typename Update>
grpc::Status LoadRun::ReadStream(grpc::ClientReader<Update>& reader, absl::Time intended) {
  Update update;
  int64_t updates = 0;
  while (reader.Read(&update)) {
    if (updates++ == 0) RecordFirstUpdate(intended, absl::Now());
  }
  grpc::Status status = reader.Finish();
  absl::MutexLock lock(&mu_);
  report_.plan_updates += updates;
  return status;
}

void LoadRun::CallSync(absl::Time intended) {
  {
    absl::MutexLock lock(&mu_);
    ++report_.sent;
    ++outstanding_;
  }
  grpc::ClientContext context;
  SetTimeout(&context, options_.timeout);
  grpc::Status status;
  switch (options_.rpc) {
    case LoadRpc::kPlanTrajectory:
      status = ReadStream(*stub_->PlanTrajectory(&context, options_.plan_request), intended);
      break;
    case LoadRpc::kPlanFleet:
      status = ReadStream(*stub_->PlanFleet(&context, options_.fleet_request), intended);
      break;
    case LoadRpc::kEvaluateRisk: {
      v1::EvaluateRiskResponse response;
      status = stub_->EvaluateRisk(&context, options_.eval_request, &response);
      break;
    }
    case LoadRpc::kPing: {
      v1::PingResponse response;
      status = stub_->Ping(&context, v1::PingRequest(), &response);
      break;
    }
    case LoadRpc::kConnect: {
      // Connected on the first call, closed when the channel goes.
      std::unique_ptr<v1::Planner::Stub> fresh = v1::Planner::NewStub(options_.new_channel());
      v1::PingResponse response;
      status = fresh->Ping(&context, v1::PingRequest(), &response);
      break;
    }
  }
  Record(intended, status, absl::Now(), context);
}

// Latency counts from `intended`, not from the actual send, so the time a
// call waited to be sent counts too: a stall shows up in the latency instead
// of quietly lowering the offered load (no coordinated omission). Every
// completed call is counted, whatever its code: a fast error is a result
// too, and the codes tell them apart.
void LoadRun::Record(absl::Time intended, const grpc::Status& status, absl::Time done,
                     const grpc::ClientContext& context) {
  const double latency_s = absl::ToDoubleSeconds(done - intended);
  std::string replica = context.peer();
  if (replica.empty()) replica = kNoReplica;
  absl::MutexLock lock(&mu_);
  ++report_.completed;
  const std::string code = StatusCodeName(status.error_code());
  ++report_.codes[code];
  ++report_.replicas[replica][code];
  report_.latency.Add(latency_s);
  interval_.Add(latency_s);
  last_done_ = std::max(last_done_, done);
  --outstanding_;
}

void LoadRun::RecordFirstUpdate(absl::Time intended, absl::Time at) {
  absl::MutexLock lock(&mu_);
  report_.first_update.Add(absl::ToDoubleSeconds(at - intended));
}

void LoadRun::RecordOverloaded() {
  absl::MutexLock lock(&mu_);
  ++report_.codes[kClientOverloaded];
}

void LoadRun::SendOpenLoop() {
  const absl::Duration interval = absl::Seconds(1.0 / options_.rate_per_s);
  // Send times are start + i * interval, not "interval after the last send":
  // sleeping that way would add each send's own delay to the next, and a
  // sender that fell behind would lower the rate instead of catching up.
  for (int64_t i = 0;; ++i) {
    const absl::Time intended = start_ + i * interval;
    if (intended >= stop_) return;
    const absl::Time now = absl::Now();
    if (intended > now) absl::SleepFor(intended - now);
    // A server that stops answering would otherwise make calls pile up in
    // the client without bound; past max_outstanding a due call is counted
    // as CLIENT_OVERLOADED instead of being sent.
    bool overloaded = false;
    {
      absl::MutexLock lock(&mu_);
      overloaded = outstanding_ >= options_.max_outstanding;
    }
    if (overloaded) {
      RecordOverloaded();
    } else {
      IssueAsync(intended);
    }
  }
}

void LoadRun::ReportProgress(const LoadProgressCallback& progress) {
  absl::Time last = start_;
  // Short naps rather than one-second sleeps, so that the end of the run is
  // noticed within 100 ms; a last, partial interval is then reported too.
  while (!finished_.load()) {
    absl::SleepFor(absl::Milliseconds(100));
    const absl::Time now = absl::Now();
    if (now - last < absl::Seconds(1) && !finished_.load()) continue;
    LoadProgress p;
    {
      absl::MutexLock lock(&mu_);
      p.elapsed_s = absl::ToDoubleSeconds(now - start_);
      p.sent = report_.sent;
      p.completed = report_.completed;
      p.errors = report_.errors();
      p.outstanding = outstanding_;
      p.interval_rps = interval_.count() / absl::ToDoubleSeconds(now - last);
      p.interval_p50_s = interval_.Percentile(50);
      p.interval_p99_s = interval_.Percentile(99);
      interval_.Clear();
    }
    last = now;
    if (progress) progress(p);
  }
}

LoadReport LoadRun::Run(const LoadProgressCallback& progress) {
  start_ = absl::Now();
  stop_ = start_ + options_.duration;
  {
    absl::MutexLock lock(&mu_);
    last_done_ = start_;
  }
  std::thread reporter([this, &progress] { ReportProgress(progress); });
  if (options_.mode == LoadMode::kClosed) {
    // One thread per caller on the blocking stub: a closed loop is as many
    // clients each waiting for its answer, which is what threads model.
    std::vector<std::thread> callers;
    for (int i = 0; i < std::max(1, options_.concurrency); ++i) {
      callers.emplace_back([this] {
        while (absl::Now() < stop_) CallSync(absl::Now());
      });
    }
    for (std::thread& t : callers) t.join();
  } else {
    SendOpenLoop();
    // Every call has a deadline, so this ends.
    absl::MutexLock lock(&mu_);
    mu_.Await(absl::Condition(
        +[](int64_t* outstanding) { return *outstanding == 0; }, &outstanding_));
  }
  finished_.store(true);
  reporter.join();
  absl::MutexLock lock(&mu_);
  // Until the last completion, not until stop_: calls sent before the stop
  // are waited for, and their time belongs to the throughput they add.
  report_.elapsed_s = absl::ToDoubleSeconds(last_done_ - start_);
  return report_;
}

nlohmann::json HistogramJson(const LatencyHistogram& h) {
  return {{"count", h.count()},
          {"min", h.min() * 1e3},
          {"mean", h.mean() * 1e3},
          {"p50", h.Percentile(50) * 1e3},
          {"p90", h.Percentile(90) * 1e3},
          {"p99", h.Percentile(99) * 1e3},
          {"p99.9", h.Percentile(99.9) * 1e3},
          {"max", h.max() * 1e3}};
}

nlohmann::json ReportJson(const LoadReport& r) {
  nlohmann::json j = {
      {"rpc", LoadRpcName(r.options.rpc)},
      {"mode", LoadModeName(r.options.mode)},
      {"duration_s", absl::ToDoubleSeconds(r.options.duration)},
      {"elapsed_s", r.elapsed_s},
      {"sent", r.sent},
      {"completed", r.completed},
      {"ok", r.ok()},
      {"errors", r.errors()},
      {"throughput_rps", r.throughput_rps()},
      {"ok_rps", r.ok_rps()},
      {"codes", r.codes},
      {"latency_ms", HistogramJson(r.latency)},
  };
  // Each replica's calls and codes ("replicas": {"ipv4:127.0.0.1:50051":
  // {"completed": 120, "codes": {"OK": 120}}, ...}).
  nlohmann::json replicas = nlohmann::json::object();
  for (const auto& [replica, codes] : r.replicas) {
    int64_t completed = 0;
    for (const auto& [code, n] : codes) completed += n;
    replicas[replica] = {{"completed", completed}, {"codes", codes}};
  }
  j["replicas"] = std::move(replicas);
  if (r.options.mode == LoadMode::kClosed) {
    j["concurrency"] = r.options.concurrency;
  } else {
    j["rate_per_s"] = r.options.rate_per_s;
  }
  if (r.options.rpc == LoadRpc::kPlanTrajectory || r.options.rpc == LoadRpc::kPlanFleet) {
    j["first_update_ms"] = HistogramJson(r.first_update);
    j["plan_updates"] = r.plan_updates;
  }
  return j;
}

std::string PhaseText(const LoadReport& r) {
  std::string out = absl::StrFormat(
      "%s, %s loop (%s), %.1f s: sent %d, completed %d, ok %d, errors %d\n"
      "  throughput %.1f calls/s (ok %.1f/s)\n"
      "  latency ms: p50 %.3f  p90 %.3f  p99 %.3f  p99.9 %.3f  (min %.3f, mean %.3f, max "
      "%.3f)\n",
      LoadRpcName(r.options.rpc), LoadModeName(r.options.mode),
      r.options.mode == LoadMode::kClosed ? absl::StrFormat("concurrency %d", r.options.concurrency)
                                          : absl::StrFormat("rate %.1f/s", r.options.rate_per_s),
      r.elapsed_s, r.sent, r.completed, r.ok(), r.errors(), r.throughput_rps(), r.ok_rps(),
      r.latency.Percentile(50) * 1e3, r.latency.Percentile(90) * 1e3,
      r.latency.Percentile(99) * 1e3, r.latency.Percentile(99.9) * 1e3, r.latency.min() * 1e3,
      r.latency.mean() * 1e3, r.latency.max() * 1e3);
  if ((r.options.rpc == LoadRpc::kPlanTrajectory || r.options.rpc == LoadRpc::kPlanFleet) &&
      r.first_update.count() > 0) {
    absl::StrAppendFormat(&out, "  first update ms: p50 %.3f  p99 %.3f; %d updates received\n",
                          r.first_update.Percentile(50) * 1e3, r.first_update.Percentile(99) * 1e3,
                          r.plan_updates);
  }
  out += "  codes:";
  for (const auto& [code, n] : r.codes) absl::StrAppendFormat(&out, " %s=%d", code, n);
  out += "\n";
  // One line per replica that answered, when the target had several.
  if (r.replicas.size() > 1) {
    for (const auto& [replica, codes] : r.replicas) {
      int64_t completed = 0;
      for (const auto& [code, n] : codes) completed += n;
      absl::StrAppendFormat(&out, "  replica %s: %d calls:", replica, completed);
      for (const auto& [code, n] : codes) absl::StrAppendFormat(&out, " %s=%d", code, n);
      out += "\n";
    }
  }
  return out;
}

// 0 rather than inf or NaN when the ceiling measured nothing: JSON has no
// infinity, and nlohmann would write null.
double Ratio(double a, double b) { return b > 0 ? a / b : 0.0; }

}  // namespace

std::string LoadRpcName(LoadRpc rpc) {
  switch (rpc) {
    case LoadRpc::kEvaluateRisk:
      return "EvaluateRisk";
    case LoadRpc::kPlanTrajectory:
      return "PlanTrajectory";
    case LoadRpc::kPlanFleet:
      return "PlanFleet";
    case LoadRpc::kPing:
      return "Ping";
    case LoadRpc::kConnect:
      return "Connect";
  }
  return "?";
}

std::string LoadModeName(LoadMode mode) { return mode == LoadMode::kClosed ? "closed" : "open"; }

int64_t LoadReport::ok() const {
  auto it = codes.find("OK");
  return it == codes.end() ? 0 : it->second;
}

int64_t LoadReport::Overloaded() const {
  auto it = codes.find(kClientOverloaded);
  return it == codes.end() ? 0 : it->second;
}

LoadReport RunLoad(const std::shared_ptr<grpc::Channel>& channel, const LoadOptions& options,
                   const LoadProgressCallback& progress) {
  assert(options.mode != LoadMode::kOpen ||
         (options.rate_per_s > 0 && std::isfinite(options.rate_per_s)));
  LoadRun run(channel, options);
  return run.Run(progress);
}

std::string LoadReportText(const LoadReport& report, const LoadReport* ceiling) {
  std::string out;
  if (ceiling != nullptr) out += "ceiling: " + PhaseText(*ceiling);
  out += PhaseText(report);
  if (ceiling != nullptr) {
    absl::StrAppendFormat(
        &out, "  vs the no-op ceiling: throughput %.3f x, p50 latency %.1f x, p99 latency %.1f x\n",
        Ratio(report.throughput_rps(), ceiling->throughput_rps()),
        Ratio(report.latency.Percentile(50), ceiling->latency.Percentile(50)),
        Ratio(report.latency.Percentile(99), ceiling->latency.Percentile(99)));
  }
  return out;
}

std::string LoadReportJson(const LoadReport& report, const LoadReport* ceiling) {
  nlohmann::json j = ReportJson(report);
  if (ceiling != nullptr) {
    j["ceiling"] = ReportJson(*ceiling);
    j["vs_ceiling"] = {
        {"throughput", Ratio(report.throughput_rps(), ceiling->throughput_rps())},
        {"p50_latency", Ratio(report.latency.Percentile(50), ceiling->latency.Percentile(50))},
        {"p99_latency", Ratio(report.latency.Percentile(99), ceiling->latency.Percentile(99))},
    };
  }
  return j.dump(2) + "\n";
}

}  // namespace riskplan::client
