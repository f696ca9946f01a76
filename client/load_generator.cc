#include "client/load_generator.h"

#include <algorithm>
#include <atomic>
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

// The shared state of one load phase.
class LoadRun {
 public:
  LoadRun(std::shared_ptr<grpc::Channel> channel, const LoadOptions& options)
      : channel_(std::move(channel)), stub_(v1::Planner::NewStub(channel_)), options_(options) {
    report_.options = options;
  }

  LoadReport Run(const LoadProgressCallback& progress);

 private:
  class PlanReactor;

  // Sends one call; `intended` is when it should have been sent.
  void IssueAsync(absl::Time intended);
  // One blocking call (closed loop).
  void CallSync(absl::Time intended);
  void Record(absl::Time intended, const grpc::Status& status, absl::Time done)
      ABSL_LOCKS_EXCLUDED(mu_);
  void RecordFirstUpdate(absl::Time intended, absl::Time at) ABSL_LOCKS_EXCLUDED(mu_);
  void RecordOverloaded() ABSL_LOCKS_EXCLUDED(mu_);
  void SendOpenLoop();
  void ReportProgress(const LoadProgressCallback& progress);

  const std::shared_ptr<grpc::Channel> channel_;
  const std::unique_ptr<v1::Planner::Stub> stub_;
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

// One streaming plan call, callback API; deletes itself when done.
class LoadRun::PlanReactor final : public grpc::ClientReadReactor<v1::PlanUpdate> {
 public:
  PlanReactor(LoadRun* run, absl::Time intended) : run_(run), intended_(intended) {
    SetTimeout(&context_, run->options_.timeout);
    run->stub_->async()->PlanTrajectory(&context_, &run->options_.plan_request, this);
    StartRead(&update_);
    StartCall();
  }
  void OnReadDone(bool ok) override {
    if (!ok) return;
    if (updates_++ == 0) run_->RecordFirstUpdate(intended_, absl::Now());
    StartRead(&update_);
  }
  void OnDone(const grpc::Status& status) override {
    {
      absl::MutexLock lock(&run_->mu_);
      run_->report_.plan_updates += updates_;
    }
    run_->Record(intended_, status, absl::Now());
    delete this;
  }

 private:
  LoadRun* const run_;
  const absl::Time intended_;
  grpc::ClientContext context_;
  v1::PlanUpdate update_;
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
      new PlanReactor(this, intended);
      return;
    case LoadRpc::kEvaluateRisk: {
      auto* context = new grpc::ClientContext;
      auto* response = new v1::EvaluateRiskResponse;
      SetTimeout(context, options_.timeout);
      stub_->async()->EvaluateRisk(context, &options_.eval_request, response,
                                   [this, context, response, intended](grpc::Status status) {
                                     Record(intended, status, absl::Now());
                                     delete response;
                                     delete context;
                                   });
      return;
    }
    case LoadRpc::kPing: {
      auto* context = new grpc::ClientContext;
      auto* response = new v1::PingResponse;
      SetTimeout(context, options_.timeout);
      static const v1::PingRequest kPing;
      stub_->async()->Ping(context, &kPing, response,
                           [this, context, response, intended](grpc::Status status) {
                             Record(intended, status, absl::Now());
                             delete response;
                             delete context;
                           });
      return;
    }
  }
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
    case LoadRpc::kPlanTrajectory: {
      std::unique_ptr<grpc::ClientReader<v1::PlanUpdate>> reader =
          stub_->PlanTrajectory(&context, options_.plan_request);
      v1::PlanUpdate update;
      int64_t updates = 0;
      while (reader->Read(&update)) {
        if (updates++ == 0) RecordFirstUpdate(intended, absl::Now());
      }
      status = reader->Finish();
      absl::MutexLock lock(&mu_);
      report_.plan_updates += updates;
      break;
    }
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
  }
  Record(intended, status, absl::Now());
}

void LoadRun::Record(absl::Time intended, const grpc::Status& status, absl::Time done) {
  const double latency_s = absl::ToDoubleSeconds(done - intended);
  absl::MutexLock lock(&mu_);
  ++report_.completed;
  ++report_.codes[StatusCodeName(status.error_code())];
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
  for (int64_t i = 0;; ++i) {
    const absl::Time intended = start_ + i * interval;
    if (intended >= stop_) return;
    const absl::Time now = absl::Now();
    if (intended > now) absl::SleepFor(intended - now);
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
  if (r.options.mode == LoadMode::kClosed) {
    j["concurrency"] = r.options.concurrency;
  } else {
    j["rate_per_s"] = r.options.rate_per_s;
  }
  if (r.options.rpc == LoadRpc::kPlanTrajectory) {
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
  if (r.options.rpc == LoadRpc::kPlanTrajectory && r.first_update.count() > 0) {
    absl::StrAppendFormat(&out, "  first update ms: p50 %.3f  p99 %.3f; %d updates received\n",
                          r.first_update.Percentile(50) * 1e3, r.first_update.Percentile(99) * 1e3,
                          r.plan_updates);
  }
  out += "  codes:";
  for (const auto& [code, n] : r.codes) absl::StrAppendFormat(&out, " %s=%d", code, n);
  out += "\n";
  return out;
}

double Ratio(double a, double b) { return b > 0 ? a / b : 0.0; }

}  // namespace

std::string LoadRpcName(LoadRpc rpc) {
  switch (rpc) {
    case LoadRpc::kEvaluateRisk:
      return "EvaluateRisk";
    case LoadRpc::kPlanTrajectory:
      return "PlanTrajectory";
    case LoadRpc::kPing:
      return "Ping";
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
