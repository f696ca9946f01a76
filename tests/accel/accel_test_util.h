// Helpers for the accel tests: a small demo-city model, configuration sets,
// polling with deadlines, the real riskplan-fpga-shim as a child process,
// in-process shims that misbehave on purpose, and the exact results a
// fixed-point board must give.
#ifndef RISKPLAN_TESTS_ACCEL_ACCEL_TEST_UTIL_H_
#define RISKPLAN_TESTS_ACCEL_ACCEL_TEST_UTIL_H_

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <list>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "accel/blobs.h"
#include "accel/fixed_point.h"
#include "accel/frame_io.h"
#include "accel/risk_engine.h"
#include "accel/shim/device.h"
#include "accel/shim/shim_session.h"
#include "core/base/random.h"
#include "core/map/demo_city.h"
#include "core/risk/risk_model.h"
#include "gtest/gtest.h"
#include "net/net.h"
#include "tests/child_process.h"

namespace riskplan::accel::testing {

// demo-city at 3 km (600 x 600 cells), default parameters. Built once.
inline std::shared_ptr<const RiskModel> SmallCity() {
  static const std::shared_ptr<const RiskModel> model = [] {
    DemoCityOptions options;
    options.size_m = 3000.0;
    auto map = MakeDemoCity(options);
    EXPECT_TRUE(map.ok()) << map.status();
    auto m = RiskModel::Create(*map, ModelParams{});
    EXPECT_TRUE(m.ok()) << m.status();
    return *m;
  }();
  return model;
}

// SmallCity() in an 8 m/s wind from the south-west (risk model version 3): its
// own impact table (the still-air weights, the wind's offsets and energies)
// and glide layer. Built once.
inline std::shared_ptr<const RiskModel> SmallCityInWind() {
  static const std::shared_ptr<const RiskModel> model = [] {
    ModelParams params;
    params.wind_speed_mps = 8.0;
    params.wind_from_deg = 225.0;
    auto m = RiskModel::Create(SmallCity()->map_ptr(), params, SmallCity()->table_ptr());
    EXPECT_TRUE(m.ok()) << m.status();
    return *m;
  }();
  return model;
}

// n configurations: two thirds along straight legs (5 m apart) at 20 to 200 m
// above ground, the rest uniform over the map, and a few undefined ones
// (outside the map, below the terrain, NaN).
inline std::vector<Pose> MixedConfigs(const RiskModel& model, size_t n, uint64_t seed) {
  const RiskMap& m = model.map();
  Rng rng(seed);
  const auto agl = [&](double x, double y, double height) {
    int i = 0, j = 0;
    if (!m.CellOf(x, y, &i, &j)) return height;
    return m.terrain(i, j) + height;
  };
  std::vector<Pose> out;
  while (out.size() < n) {
    const double r = rng.Uniform();
    if (r < 0.02) {
      // Undefined: outside the map, below the terrain, not finite.
      const int kind = static_cast<int>(rng.Uniform() * 3);
      if (kind == 0) out.push_back({m.x0() - 10.0, m.y0() + 100.0, 200.0, 0.0});
      if (kind == 1)
        out.push_back(
            {m.x0() + 500.0, m.y0() + 500.0, agl(m.x0() + 500.0, m.y0() + 500.0, -1.0), 1.0});
      if (kind == 2) out.push_back({m.x0() + 500.0, m.y0() + 500.0, std::nan(""), 1.0});
      continue;
    }
    const double height = 20.0 + 180.0 * rng.Uniform();
    if (r < 0.35) {
      out.push_back(Pose{m.x0() + m.width_m() * rng.Uniform(),
                         m.y0() + m.height_m() * rng.Uniform(), 0.0, kTwoPi * rng.Uniform()});
      out.back().z = agl(out.back().x, out.back().y, height);
      continue;
    }
    // A leg of up to 60 samples 5 m apart (possibly running off the map).
    const double theta = kTwoPi * rng.Uniform();
    double x = m.x0() + m.width_m() * rng.Uniform();
    double y = m.y0() + m.height_m() * rng.Uniform();
    for (int k = 0; k < 60 && out.size() < n; ++k) {
      out.push_back(Pose{x, y, agl(x, y, height), theta});
      x += 5.0 * std::cos(theta);
      y += 5.0 * std::sin(theta);
    }
  }
  return out;
}

// Bitwise equality of every field.
inline bool SameRisk(const ConfigurationRisk& a, const ConfigurationRisk& b) {
  const auto same = [](double x, double y) { return std::memcmp(&x, &y, sizeof(x)) == 0; };
  return a.defined == b.defined && same(a.risk, b.risk) && same(a.impact_factor, b.impact_factor) &&
         same(a.expected_shelter, b.expected_shelter) &&
         same(a.casualty_probability, b.casualty_probability) &&
         same(a.exposed_area_m2, b.exposed_area_m2) && a.height_bin == b.height_bin &&
         a.heading_bin == b.heading_bin;
}

// Polls `pred` every 2 ms until it holds or `timeout` passes.
template <typename Pred>
bool WaitFor(Pred pred, absl::Duration timeout = absl::Seconds(20)) {
  const absl::Time deadline = absl::Now() + timeout;
  while (!pred()) {
    if (absl::Now() > deadline) return false;
    absl::SleepFor(absl::Milliseconds(2));
  }
  return true;
}

// The real riskplan-fpga-shim (RISKPLAN_BIN_DIR), started with `args` and
// --listen, and read up to its readiness line.
class ShimProcess {
 public:
  // Null (with a test failure) when the shim does not come up within 20 s.
  static std::unique_ptr<ShimProcess> Start(const std::vector<std::string>& args,
                                            const std::string& listen = "127.0.0.1:0") {
    std::unique_ptr<ShimProcess> shim = Launch(args, listen, /*capture_stderr=*/false);
    if (shim == nullptr || shim->endpoint().empty()) {
      ADD_FAILURE() << "riskplan-fpga-shim did not come up: '"
                    << (shim == nullptr ? "" : shim->stdout_) << "'";
      return nullptr;
    }
    return shim;
  }
  // Like Start, but returns the process whether or not it came up (then
  // endpoint() is empty: it refused its flags, say); with `capture_stderr`
  // its stderr goes to a file that Stderr() reads. Null only when no process
  // could be started.
  static std::unique_ptr<ShimProcess> Launch(const std::vector<std::string>& args,
                                             const std::string& listen, bool capture_stderr) {
    auto shim = std::unique_ptr<ShimProcess>(new ShimProcess());
    int err_fd = -1;
    if (capture_stderr) {
      char path[] = "/tmp/riskplan-shim-stderr-XXXXXX";
      err_fd = mkstemp(path);
      if (err_fd < 0) return nullptr;
      shim->stderr_path_ = path;
    }
    int out[2];
    if (pipe2(out, O_CLOEXEC) != 0) return nullptr;
    const std::string binary = absl::StrCat(RISKPLAN_BIN_DIR, "/riskplan-fpga-shim");
    std::vector<std::string> argv_text = {binary, "--listen=" + listen};
    argv_text.insert(argv_text.end(), args.begin(), args.end());
    absl::StatusOr<pid_t> pid = riskplan::testing::SpawnProcess(
        argv_text, riskplan::testing::SpawnOptions{.stdout_fd = out[1], .stderr_fd = err_fd});
    close(out[1]);
    if (err_fd >= 0) close(err_fd);
    if (!pid.ok()) {
      close(out[0]);
      return nullptr;
    }
    shim->pid_ = *pid;
    // Read up to the readiness line, with a deadline.
    std::string& text = shim->stdout_;
    const absl::Time deadline = absl::Now() + absl::Seconds(20);
    while (text.find('\n') == std::string::npos && absl::Now() < deadline) {
      pollfd p{out[0], POLLIN, 0};
      if (poll(&p, 1, 100) <= 0) continue;
      char buf[256];
      const ssize_t got = read(out[0], buf, sizeof(buf));
      if (got <= 0) break;
      text.append(buf, static_cast<size_t>(got));
    }
    close(out[0]);
    const std::string marker = "riskplan-fpga-shim listening on ";
    const size_t at = text.find(marker);
    const size_t end = text.find('\n');
    if (at != std::string::npos && end != std::string::npos) {
      shim->endpoint_ = text.substr(at + marker.size(), end - at - marker.size());
    }
    return shim;
  }
  ~ShimProcess() {
    Kill();
    if (!stderr_path_.empty()) unlink(stderr_path_.c_str());
  }
  const std::string& endpoint() const { return endpoint_; }
  // SIGKILL and reap.
  void Kill() {
    if (pid_ <= 0) return;
    kill(pid_, SIGKILL);
    waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }
  // SIGTERM, then waits for it to exit: its exit code (-1: killed by a
  // signal, or already gone).
  int Terminate() {
    if (pid_ <= 0) return -1;
    kill(pid_, SIGTERM);
    int status = 0;
    waitpid(pid_, &status, 0);
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  // What it wrote to stderr so far (Launch with capture_stderr only).
  std::string Stderr() const {
    std::ifstream in(stderr_path_);
    std::stringstream all;
    all << in.rdbuf();
    return all.str();
  }

 private:
  int pid_ = -1;
  std::string endpoint_;
  std::string stdout_;
  std::string stderr_path_;
};

// 127.0.0.1:PORT held bound but not listening, with SO_REUSEADDR, for a
// riskplan-fpga-shim that is stopped and started again on the same port.
// The shim sets SO_REUSEADDR too, so it can listen beside this socket; and
// while it is down no connect() on the machine can take the port as its
// source port (Linux never picks a port that a socket bound explicitly), the
// worker's own reconnects to it included (a connect from a port to itself
// would succeed and hold it). So the restarted shim always gets it back.
class ReservedPort {
 public:
  ReservedPort() : socket_(socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0)) {
    const int one = 1;
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof(addr);
    if (!socket_.valid() ||
        setsockopt(socket_.fd(), SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one)) != 0 ||
        bind(socket_.fd(), reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0 ||
        getsockname(socket_.fd(), reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
      error_ = std::string("cannot reserve a port: ") + std::strerror(errno);
      return;
    }
    endpoint_ = "127.0.0.1:" + std::to_string(ntohs(addr.sin_port));
  }
  bool ok() const { return error_.empty(); }
  const std::string& error() const { return error_; }
  const std::string& endpoint() const { return endpoint_; }

 private:
  net::Socket socket_;
  std::string endpoint_;
  std::string error_;
};

// An engine whose only worker is the board at `endpoint` (no CPU workers,
// callers do not compute while it is up: every chunk goes to the board),
// returned once that worker is up. Null, with a test failure, when the
// engine cannot be made; a test failure when the board never comes up.
// Its users check that every configuration went to the board, so the
// worker's deadlines are far longer than the production defaults (2 s per
// EVAL, plus 20 us a site): a simulated RTL board on a loaded machine can take
// longer than that for a chunk, which would then fall back to the CPU.
inline std::unique_ptr<RiskEngine> BoardOnlyEngine(const std::string& endpoint,
                                                   int min_chunk_configs = 512) {
  RiskEngineOptions options;
  options.cpu_workers = 0;
  options.caller_runs = false;
  options.min_chunk_configs = min_chunk_configs;
  options.fpga_shims = {endpoint};
  options.fpga.client.eval_timeout = absl::Minutes(10);
  options.fpga.client.hello_timeout = absl::Seconds(60);
  options.fpga.client.ping_timeout = absl::Seconds(60);
  options.fpga.client.upload_timeout = absl::Seconds(60);
  absl::StatusOr<std::unique_ptr<RiskEngine>> engine = RiskEngine::Create(options);
  if (!engine.ok()) {
    ADD_FAILURE() << engine.status();
    return nullptr;
  }
  EXPECT_TRUE(WaitFor([&] { return (*engine)->Stats().fpga[0].state == WorkerState::kUp; }))
      << "the board at " << endpoint << " never came up";
  return *std::move(engine);
}

// What a board with `format` must answer for q: the model's fixed-point
// sums, converted and finished on the server like FpgaWorker does.
class FpgaExpectation {
 public:
  FpgaExpectation(const RiskModel& model, const NumberFormat& format)
      : model_(model), format_(format) {
    map_ = *QuantizeMapBlob(EncodeMapBlob(model.map()), format, 32);
    kernels_ = *QuantizeKernelsBlob(EncodeKernelsBlob(KernelSetOf(model.table())), format, 63);
  }
  ConfigurationRisk Evaluate(const Pose& q) const {
    KernelSite site;
    if (!model_.Locate(q, &site)) return ConfigurationRisk{};
    Accumulator impact = 0, shelter = 0;
    ModelEwmm(map_, kernels_.kernel(site.height_bin, site.heading_bin), site.impact_i,
              site.impact_j, &impact, &shelter);
    return model_.FromSums(
        site, AccumulatorToDouble(impact, format_.weight_frac_bits + map_.density_exponent),
        AccumulatorToDouble(shelter, format_.weight_frac_bits + map_.shelter_exponent));
  }

 private:
  const RiskModel& model_;
  NumberFormat format_;
  QuantizedMap map_;
  QuantizedKernelTable kernels_;
};

enum class Misbehaviour {
  kNone,
  kHang,           // big EVALs: never answered
  kCorruptFrame,   // big EVALs: a payload byte flipped (CRC mismatch)
  kGarbageValues,  // big EVALs: a valid frame with absurd sums
  kWrongVersion,   // every reply in protocol version 2
  kCloseOnEval,    // big EVALs: the connection is closed
  kSilent,         // accepts connections, never answers anything (not even HELLO)
  kCorruptHeader,  // big EVALs: a header byte flipped (header checksum mismatch)
  kWrongSums,      // big EVALs: a valid frame, every impact sum off by 2^-20 (plausible)
  kSlow,           // big EVALs: the right reply, held until release_slow_replies()
  kSlowUpload,     // big PUT_BLOBs (a model's map or kernels): each chunk answered 60 s late
};

// An in-process shim serving ShimSession over a ModelDevice, misbehaving as
// told on "big" EVALs (more sites than the known-answer batch has).
class FakeShim {
 public:
  explicit FakeShim(Misbehaviour misbehaviour, NumberFormat format = NumberFormat::Board())
      : misbehaviour_(misbehaviour), device_(format, "fake"), store_(format, 63, 1u << 30) {
    context_.device = &device_;
    context_.store = &store_;
    auto listener = net::ListenTcp("127.0.0.1:0", &endpoint_);
    EXPECT_TRUE(listener.ok()) << listener.status();
    listener_ = *std::move(listener);
    accept_thread_ = std::thread([this] { AcceptLoop(); });
  }
  ~FakeShim() {
    stop_.store(true);
    accept_thread_.join();
    std::list<std::thread> threads;
    {
      absl::MutexLock lock(&mu_);
      for (net::Socket& s : sockets_) s.Shutdown();
      threads.swap(threads_);
    }
    for (std::thread& t : threads) t.join();
  }
  const std::string& endpoint() const { return endpoint_; }
  int misbehaved() const { return misbehaved_.load(); }
  void set_misbehaviour(Misbehaviour m) { misbehaviour_.store(m); }
  // kSlow's held replies go out now (and later ones at once).
  void release_slow_replies() { release_slow_.store(true); }

 private:
  // The known-answer batch has fewer sites than this.
  static constexpr size_t kBigEval = 100;

  void AcceptLoop() {
    while (!stop_.load()) {
      auto socket = net::Accept(listener_, absl::Now() + absl::Milliseconds(20));
      if (!socket.ok()) continue;
      absl::MutexLock lock(&mu_);
      sockets_.push_back(*std::move(socket));
      net::Socket* s = &sockets_.back();
      threads_.emplace_back([this, s] { Serve(s); });
    }
  }

  void Serve(net::Socket* socket) {
    ShimSession session(&context_);
    std::string payload;
    while (!stop_.load()) {
      FrameHeader header;
      if (!ReadFrame(*socket, kMaxPayloadBytes, absl::Now() + absl::Seconds(60), &header, &payload)
               .ok()) {
        break;
      }
      const Misbehaviour m = misbehaviour_.load();
      if (m == Misbehaviour::kSlowUpload && header.type == MessageType::kPutBlob &&
          payload.size() > (size_t{64} << 10)) {
        ++misbehaved_;
        const absl::Time until = absl::Now() + absl::Seconds(60);
        while (!stop_.load() && absl::Now() < until) absl::SleepFor(absl::Milliseconds(10));
      }
      if (m == Misbehaviour::kSilent) {
        ++misbehaved_;
        continue;
      }
      bool close = false;
      std::string reply = session.Handle(header, payload, &close);
      const bool big = header.type == MessageType::kEval && payload.size() > 68 + 12 * kBigEval;
      if (m == Misbehaviour::kWrongVersion) {
        ++misbehaved_;
        reply = EncodeFrame(static_cast<MessageType>(reply[6] | reply[7] << 8), header.request_id,
                            absl::string_view(reply).substr(kFrameHeaderBytes), 2);
      } else if (big && m == Misbehaviour::kHang) {
        ++misbehaved_;
        continue;  // never answered; the client times out and hangs up
      } else if (big && m == Misbehaviour::kSlow) {
        ++misbehaved_;
        // Late by the test's decision, not by a time: a fixed delay raced
        // the caller's own reaction on a loaded machine under TSan.
        while (!release_slow_.load() && !stop_.load()) absl::SleepFor(absl::Milliseconds(5));
      } else if (big && m == Misbehaviour::kCloseOnEval) {
        ++misbehaved_;
        break;
      } else if (big && m == Misbehaviour::kCorruptFrame) {
        ++misbehaved_;
        reply[kFrameHeaderBytes + reply.size() / 3] ^= 0x10;
      } else if (big && m == Misbehaviour::kCorruptHeader) {
        ++misbehaved_;
        reply[17] ^= 0x01;  // payload_bytes (offset 16, little endian)
      } else if (big && m == Misbehaviour::kWrongSums) {
        ++misbehaved_;
        EvalReply r;
        if (DecodeEvalReply(absl::string_view(reply).substr(kFrameHeaderBytes), &r).ok()) {
          // Right scales, values in range, each I off by about 1e-6 (a
          // broken low-order lane bit): only a recomputation can tell.
          for (Accumulator& a : r.impact) a ^= Accumulator{1} << (r.impact_scale - 20);
          reply = EncodeFrame(MessageType::kEvalReply, header.request_id, EncodeEvalReply(r));
        }
      } else if (big && m == Misbehaviour::kGarbageValues) {
        ++misbehaved_;
        EvalReply r;
        if (DecodeEvalReply(absl::string_view(reply).substr(kFrameHeaderBytes), &r).ok()) {
          for (Accumulator& a : r.shelter) a = ~Accumulator{0} >> 1;
          reply = EncodeFrame(MessageType::kEvalReply, header.request_id, EncodeEvalReply(r));
        }
      }
      if (!net::SendAll(*socket, reply, absl::Now() + absl::Seconds(10)).ok() || close) break;
    }
    socket->Shutdown();
  }

  std::atomic<Misbehaviour> misbehaviour_;
  ModelDevice device_;
  BlobStore store_;
  ShimContext context_;
  net::Socket listener_;
  std::string endpoint_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> release_slow_{false};
  std::atomic<int> misbehaved_{0};
  std::thread accept_thread_;
  absl::Mutex mu_;
  std::list<net::Socket> sockets_ ABSL_GUARDED_BY(mu_);
  std::list<std::thread> threads_ ABSL_GUARDED_BY(mu_);
};

}  // namespace riskplan::accel::testing

#endif  // RISKPLAN_TESTS_ACCEL_ACCEL_TEST_UTIL_H_
