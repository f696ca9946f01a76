// Fault drills: boards that die, hang, never answer, lie (corrupt frames,
// absurd sums, plausible but wrong sums), speak another protocol version,
// restart, or are removed. In every drill every request is answered, each result is
// exactly either the CPU's or the board's (never anything else, never
// missing), and every configuration is counted exactly once across workers.
#include <atomic>
#include <memory>
#include <thread>
#include <vector>

#include "accel/risk_engine.h"
#include "accel_test_util.h"
#include "gtest/gtest.h"

namespace riskplan::accel {
namespace {

using testing::FakeShim;
using testing::FpgaExpectation;
using testing::Misbehaviour;
using testing::MixedConfigs;
using testing::ReservedPort;
using testing::SameRisk;
using testing::ShimProcess;
using testing::SmallCity;
using testing::WaitFor;

// How long the worker waits for the board. A drill whose fault is not a
// timeout waits far longer than any loaded machine needs, so that only the
// drilled fault can fail a request and the counts it asserts (zero failures,
// every chunk on the board) hold however slow the machine is. Only the drills
// of a board that never answers wait briefly, so that they end soon; the
// board's good answers in those drills (HELLO, PING, the known-answer batch)
// are a few hundred bytes computed in microseconds.
struct DrillTimeouts {
  absl::Duration eval = absl::Seconds(30);
  absl::Duration hello = absl::Seconds(30);
  absl::Duration ping = absl::Seconds(30);
};

struct Drill {
  absl::Mutex mu;
  std::vector<WorkerEvent> events;
  // Declared last, destroyed first: its workers report their last event
  // ("stopped") while the engine shuts down, into `events`.
  std::unique_ptr<RiskEngine> engine;

  // CPU fallback only through the calling thread (no CPU workers, callers
  // do not run chunks while a board is up): every chunk that can go to the
  // board does. Fails the test (fatally: call it inside
  // ASSERT_NO_FATAL_FAILURE) when the engine cannot be made.
  void Start(const std::string& endpoint, int cpu_workers = 0,
             size_t blob_cache_bytes = size_t{256} << 20, DrillTimeouts timeouts = {}) {
    RiskEngineOptions options;
    options.cpu_workers = cpu_workers;
    options.blob_cache_bytes = blob_cache_bytes;
    options.caller_runs = false;
    options.min_chunk_configs = 1000;
    options.max_chunk_configs = 4000;
    options.fpga_shims = {endpoint};
    options.fpga.client.eval_timeout = timeouts.eval;
    options.fpga.client.ping_timeout = timeouts.ping;
    options.fpga.client.hello_timeout = timeouts.hello;
    options.fpga.client.upload_timeout = absl::Seconds(30);
    options.fpga.backoff_initial = absl::Milliseconds(10);
    options.fpga.backoff_max = absl::Milliseconds(100);
    options.fpga.ping_interval = absl::Milliseconds(100);
    options.on_worker_event = [this](const WorkerEvent& e) {
      absl::MutexLock lock(&mu);
      events.push_back(e);
    };
    absl::StatusOr<std::unique_ptr<RiskEngine>> created = RiskEngine::Create(options);
    ASSERT_TRUE(created.ok()) << created.status();
    engine = *std::move(created);
  }

  WorkerState state() { return engine->Stats().fpga[0].state; }
  bool WaitForState(WorkerState s) {
    return WaitFor([&] { return state() == s; });
  }
  bool SawState(WorkerState s) {
    absl::MutexLock lock(&mu);
    for (const WorkerEvent& e : events) {
      if (e.to == s) return true;
    }
    return false;
  }
  std::string Reasons() {
    absl::MutexLock lock(&mu);
    std::string all;
    for (const WorkerEvent& e : events) {
      all += std::string(WorkerStateName(e.from)) + "->" + std::string(WorkerStateName(e.to)) +
             ": " + e.reason + "\n";
    }
    return all;
  }

  // Evaluates and checks every result; returns how many came from the board.
  size_t EvaluateAndCheck(const std::vector<Pose>& configs, const NumberFormat& format) {
    const RiskModel& model = *SmallCity();
    std::vector<ConfigurationRisk> out(configs.size());
    for (ConfigurationRisk& r : out) r.risk = -1.0;
    const RiskEngineStats before = engine->Stats();
    EXPECT_TRUE(engine->Evaluate(model, configs, out).ok());
    const FpgaExpectation board(model, format);
    size_t from_board = 0;
    for (size_t n = 0; n < configs.size(); ++n) {
      const ConfigurationRisk cpu = model.Evaluate(configs[n]);
      if (SameRisk(out[n], cpu)) continue;
      EXPECT_TRUE(SameRisk(out[n], board.Evaluate(configs[n])))
          << "configuration " << n << " is neither the CPU's nor the board's result";
      ++from_board;
    }
    // Counted once: callers + CPU workers + boards = configurations.
    const RiskEngineStats after = engine->Stats();
    uint64_t counted = (after.caller_configurations - before.caller_configurations) +
                       (after.fpga[0].configurations - before.fpga[0].configurations);
    for (size_t w = 0; w < after.cpu.size(); ++w) {
      counted += after.cpu[w].configurations - before.cpu[w].configurations;
    }
    EXPECT_EQ(counted, configs.size());
    return from_board;
  }
};

std::vector<Pose> Configs(size_t n, uint64_t seed) { return MixedConfigs(*SmallCity(), n, seed); }

TEST(FaultDrillTest, ShimKilledMidBatch) {
  auto shim = ShimProcess::Start({"--device=model"});
  ASSERT_NE(shim, nullptr);
  Drill drill;
  ASSERT_NO_FATAL_FAILURE(drill.Start(shim->endpoint()));
  ASSERT_TRUE(drill.WaitForState(WorkerState::kUp)) << drill.Reasons();
  const std::vector<Pose> configs = Configs(120000, 1);
  // Kill the shim once the board has finished a chunk of this batch (others
  // are then still queued or in flight).
  std::thread killer([&] {
    // However long the board's first chunk takes (more than 20 s for the
    // TSan-built shim on a loaded machine); the deadline only ends a hang.
    EXPECT_TRUE(WaitFor([&] { return drill.engine->Stats().fpga[0].chunks >= 1; },
                        absl::Minutes(10)));
    shim->Kill();
  });
  const size_t from_board = drill.EvaluateAndCheck(configs, NumberFormat::Board());
  killer.join();
  EXPECT_GT(from_board, 0u);
  EXPECT_LT(from_board, configs.size()) << "the CPU took over the rest";
  EXPECT_GT(drill.engine->Stats().caller_configurations, 0u) << "the CPU took over the rest";
  EXPECT_TRUE(drill.SawState(WorkerState::kSuspect)) << drill.Reasons();
  EXPECT_TRUE(drill.WaitForState(WorkerState::kDown) || drill.state() == WorkerState::kProbing);
  // Later requests are answered by the CPU alone.
  EXPECT_EQ(drill.EvaluateAndCheck(Configs(5000, 2), NumberFormat::Board()), 0u);
}

TEST(FaultDrillTest, ShimHangs) {
  FakeShim fake(Misbehaviour::kHang);
  Drill drill;
  ASSERT_NO_FATAL_FAILURE(
      drill.Start(fake.endpoint(), 0, size_t{256} << 20, {.eval = absl::Seconds(1)}));
  ASSERT_TRUE(drill.WaitForState(WorkerState::kUp)) << drill.Reasons();
  EXPECT_EQ(drill.EvaluateAndCheck(Configs(20000, 3), NumberFormat::Board()), 0u);
  EXPECT_GT(fake.misbehaved(), 0);
  EXPECT_TRUE(drill.SawState(WorkerState::kSuspect)) << drill.Reasons();
  const RiskEngineStats stats = drill.engine->Stats();
  EXPECT_GT(stats.fpga[0].failures, 0u);
  EXPECT_NE(stats.fpga[0].last_error.find("deadline"), std::string::npos)
      << stats.fpga[0].last_error;
  // It answers HELLO, PING and the known-answer batch, so each recheck
  // passes; failing real work twice in a row sends it down (with a growing
  // back-off) instead of back to work at once. (How many of a batch's chunks
  // reach the board before the CPU has done the rest depends on timing: more
  // batches until it has failed twice, each answered correctly.)
  const std::string down = "up->down: 2 chunks failed in a row";
  for (uint64_t seed = 30; seed < 40 && drill.Reasons().find(down) == std::string::npos; ++seed) {
    EXPECT_EQ(drill.EvaluateAndCheck(Configs(20000, seed), NumberFormat::Board()), 0u);
  }
  EXPECT_NE(drill.Reasons().find(down), std::string::npos) << drill.Reasons();
}

TEST(FaultDrillTest, ShimNeverAnswersHello) {
  FakeShim fake(Misbehaviour::kSilent);
  Drill drill;
  ASSERT_NO_FATAL_FAILURE(
      drill.Start(fake.endpoint(), 0, size_t{256} << 20, {.hello = absl::Milliseconds(400)}));
  ASSERT_TRUE(WaitFor([&] { return drill.SawState(WorkerState::kDown); })) << drill.Reasons();
  EXPECT_EQ(drill.EvaluateAndCheck(Configs(10000, 12), NumberFormat::Board()), 0u);
  EXPECT_FALSE(drill.SawState(WorkerState::kUp)) << drill.Reasons();
  EXPECT_GT(fake.misbehaved(), 0);
  EXPECT_NE(drill.Reasons().find("probe failed"), std::string::npos) << drill.Reasons();
  EXPECT_NE(drill.Reasons().find("deadline"), std::string::npos) << drill.Reasons();
}

TEST(FaultDrillTest, ShimCorruptsFrameHeaders) {
  FakeShim fake(Misbehaviour::kCorruptHeader);
  Drill drill;
  ASSERT_NO_FATAL_FAILURE(drill.Start(fake.endpoint()));
  ASSERT_TRUE(drill.WaitForState(WorkerState::kUp)) << drill.Reasons();
  EXPECT_EQ(drill.EvaluateAndCheck(Configs(20000, 13), NumberFormat::Board()), 0u);
  EXPECT_GT(fake.misbehaved(), 0);
  EXPECT_NE(drill.Reasons().find("header checksum"), std::string::npos) << drill.Reasons();
}

TEST(FaultDrillTest, ShimReturnsPlausibleButWrongSums) {
  FakeShim fake(Misbehaviour::kWrongSums);
  Drill drill;
  ASSERT_NO_FATAL_FAILURE(drill.Start(fake.endpoint()));
  ASSERT_TRUE(drill.WaitForState(WorkerState::kUp)) << drill.Reasons();
  EXPECT_EQ(drill.EvaluateAndCheck(Configs(20000, 14), NumberFormat::Board()), 0u);
  EXPECT_GT(fake.misbehaved(), 0);
  EXPECT_NE(drill.Reasons().find("failed a spot check"), std::string::npos) << drill.Reasons();
  const FpgaWorkerStats stats = drill.engine->Stats().fpga[0];
  EXPECT_GT(stats.audit_failures, 0u);
  EXPECT_GE(stats.audited, stats.audit_failures);
}

TEST(FaultDrillTest, BlobsAreUploadedOnceAndSpotChecksPass) {
  auto shim = ShimProcess::Start({"--device=model"});
  ASSERT_NE(shim, nullptr);
  Drill drill;
  ASSERT_NO_FATAL_FAILURE(drill.Start(shim->endpoint()));
  ASSERT_TRUE(drill.WaitForState(WorkerState::kUp)) << drill.Reasons();
  size_t from_board = 0;
  for (uint64_t seed = 15; seed < 18; ++seed) {
    from_board += drill.EvaluateAndCheck(Configs(6000, seed), NumberFormat::Board());
  }
  EXPECT_GT(from_board, 0u);
  const RiskEngineStats engine_stats = drill.engine->Stats();
  EXPECT_EQ(engine_stats.caller_configurations, 0u) << "a healthy board took every chunk";
  const FpgaWorkerStats& stats = engine_stats.fpga[0];
  EXPECT_EQ(stats.configurations, 18000u);
  // The map and the kernel set, each once, whatever the number of batches.
  EXPECT_EQ(stats.uploads, 2u);
  EXPECT_GE(stats.audited, 2 * stats.chunks);
  EXPECT_EQ(stats.audit_failures, 0u);
  EXPECT_EQ(stats.failures, 0u);
  EXPECT_FALSE(drill.SawState(WorkerState::kSuspect)) << drill.Reasons();
}

TEST(FaultDrillTest, AModelTooLargeForTheBlobCacheIsLeftToTheCpu) {
  FakeShim fake(Misbehaviour::kNone);
  Drill drill;
  ASSERT_NO_FATAL_FAILURE(
      drill.Start(fake.endpoint(), /*cpu_workers=*/0, /*blob_cache_bytes=*/1 << 20));
  ASSERT_TRUE(drill.WaitForState(WorkerState::kUp)) << drill.Reasons();
  EXPECT_EQ(drill.EvaluateAndCheck(Configs(10000, 19), NumberFormat::Board()), 0u);
  const RiskEngineStats stats = drill.engine->Stats();
  EXPECT_GT(stats.fpga[0].unsupported, 0u);
  EXPECT_EQ(stats.fpga[0].failures, 0u);
  EXPECT_EQ(stats.fpga[0].state, WorkerState::kUp) << "not the board's fault";
  EXPECT_NE(stats.fpga[0].last_error.find("larger than the blob cache"), std::string::npos)
      << stats.fpga[0].last_error;
  EXPECT_EQ(stats.blob_cache_bytes, 0u);
}

TEST(FaultDrillTest, ShimCorruptsFrames) {
  FakeShim fake(Misbehaviour::kCorruptFrame);
  Drill drill;
  ASSERT_NO_FATAL_FAILURE(drill.Start(fake.endpoint()));
  ASSERT_TRUE(drill.WaitForState(WorkerState::kUp)) << drill.Reasons();
  EXPECT_EQ(drill.EvaluateAndCheck(Configs(20000, 4), NumberFormat::Board()), 0u);
  EXPECT_GT(fake.misbehaved(), 0);
  EXPECT_NE(drill.Reasons().find("checksum"), std::string::npos) << drill.Reasons();
}

TEST(FaultDrillTest, ShimReturnsGarbageInValidFrames) {
  FakeShim fake(Misbehaviour::kGarbageValues);
  Drill drill;
  ASSERT_NO_FATAL_FAILURE(drill.Start(fake.endpoint()));
  ASSERT_TRUE(drill.WaitForState(WorkerState::kUp)) << drill.Reasons();
  EXPECT_EQ(drill.EvaluateAndCheck(Configs(20000, 5), NumberFormat::Board()), 0u);
  EXPECT_GT(fake.misbehaved(), 0);
  EXPECT_NE(drill.Reasons().find("implausible"), std::string::npos) << drill.Reasons();
}

TEST(FaultDrillTest, ShimClosesTheConnectionOnEval) {
  FakeShim fake(Misbehaviour::kCloseOnEval);
  Drill drill;
  ASSERT_NO_FATAL_FAILURE(drill.Start(fake.endpoint(), /*cpu_workers=*/1));
  ASSERT_TRUE(drill.WaitForState(WorkerState::kUp)) << drill.Reasons();
  EXPECT_EQ(drill.EvaluateAndCheck(Configs(20000, 6), NumberFormat::Board()), 0u);
  EXPECT_GT(fake.misbehaved(), 0);
}

TEST(FaultDrillTest, ProtocolVersionMismatch) {
  FakeShim fake(Misbehaviour::kWrongVersion);
  Drill drill;
  ASSERT_NO_FATAL_FAILURE(drill.Start(fake.endpoint()));
  ASSERT_TRUE(WaitFor([&] { return drill.SawState(WorkerState::kDown); }));
  EXPECT_EQ(drill.EvaluateAndCheck(Configs(10000, 7), NumberFormat::Board()), 0u);
  EXPECT_FALSE(drill.SawState(WorkerState::kUp));
  EXPECT_NE(drill.Reasons().find("protocol version 2"), std::string::npos) << drill.Reasons();
}

TEST(FaultDrillTest, ShimRestartsAndTheWorkerReturnsToService) {
  // The port stays reserved while the board is down, so the restarted shim
  // gets it back: no other connection (the worker's own reconnects included)
  // can take it as its source port meanwhile.
  const ReservedPort port;
  ASSERT_TRUE(port.ok()) << port.error();
  auto shim = ShimProcess::Start({"--device=model"}, port.endpoint());
  ASSERT_NE(shim, nullptr);
  ASSERT_EQ(shim->endpoint(), port.endpoint());
  Drill drill;
  ASSERT_NO_FATAL_FAILURE(drill.Start(port.endpoint()));
  ASSERT_TRUE(drill.WaitForState(WorkerState::kUp)) << drill.Reasons();
  EXPECT_GT(drill.EvaluateAndCheck(Configs(8000, 8), NumberFormat::Board()), 0u);
  shim->Kill();
  ASSERT_TRUE(WaitFor([&] { return drill.state() != WorkerState::kUp; })) << drill.Reasons();
  // Meanwhile the CPU answers.
  EXPECT_EQ(drill.EvaluateAndCheck(Configs(8000, 9), NumberFormat::Board()), 0u);
  // The board comes back on the same port (a restarted board has lost its
  // blobs: they are uploaded again).
  shim = ShimProcess::Start({"--device=model"}, port.endpoint());
  ASSERT_NE(shim, nullptr);
  ASSERT_TRUE(drill.WaitForState(WorkerState::kUp)) << drill.Reasons();
  const uint64_t uploads = drill.engine->Stats().fpga[0].uploads;
  EXPECT_GT(drill.EvaluateAndCheck(Configs(8000, 10), NumberFormat::Board()), 0u);
  EXPECT_GT(drill.engine->Stats().fpga[0].uploads, uploads);
  EXPECT_TRUE(drill.SawState(WorkerState::kProbing));
}

TEST(FaultDrillTest, RemovingAWorkerMidBatch) {
  auto shim = ShimProcess::Start({"--device=model"});
  ASSERT_NE(shim, nullptr);
  Drill drill;
  ASSERT_NO_FATAL_FAILURE(drill.Start(shim->endpoint()));
  ASSERT_TRUE(drill.WaitForState(WorkerState::kUp)) << drill.Reasons();
  std::thread remover([&] {
    // Ordering, not speed: the worker goes once the board has answered a
    // chunk, however long that takes (a sanitized shim on a loaded machine
    // took more than 20 s); the deadline only ends a hang.
    EXPECT_TRUE(WaitFor([&] { return drill.engine->Stats().fpga[0].chunks >= 1; },
                        absl::Minutes(10)));
    EXPECT_TRUE(drill.engine->RemoveFpgaWorker(shim->endpoint()).ok());
  });
  const RiskModel& model = *SmallCity();
  const std::vector<Pose> configs = Configs(120000, 11);
  std::vector<ConfigurationRisk> out(configs.size());
  for (ConfigurationRisk& r : out) r.risk = -1.0;
  ASSERT_TRUE(drill.engine->Evaluate(model, configs, out).ok());
  remover.join();
  const FpgaExpectation board(model, NumberFormat::Board());
  size_t from_board = 0;
  for (size_t n = 0; n < configs.size(); ++n) {
    const bool cpu = SameRisk(out[n], model.Evaluate(configs[n]));
    ASSERT_TRUE(cpu || SameRisk(out[n], board.Evaluate(configs[n]))) << n;
    from_board += !cpu;
  }
  EXPECT_GT(from_board, 0u);
  EXPECT_LT(from_board, configs.size()) << "the CPU took over after the removal";
  const RiskEngineStats stats = drill.engine->Stats();
  EXPECT_TRUE(stats.fpga.empty());
  EXPECT_GT(stats.caller_configurations, 0u);
}

}  // namespace
}  // namespace riskplan::accel
