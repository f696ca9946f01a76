// Three riskplan-server replicas on loopback behind one client target (a
// static list, round-robin): fleets and an EvaluateRisk load spread over
// them while one replica is SIGKILLed and another SIGTERMed mid-run. Every
// mission still gets exactly one final result with a trajectory whose risk is
// EvaluateRisk's bit for bit, every EvaluateRisk call succeeds (gRPC's retry
// policy takes it to another replica), and once the two are gone the load is
// all on the one left.
#include <signal.h>

#include <atomic>
#include <map>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/synchronization/mutex.h"
#include "absl/synchronization/notification.h"
#include "absl/time/clock.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/integration/requests.h"
#include "tests/integration/server_process.h"

namespace riskplan::testing {
namespace {

constexpr int kReplicas = 3;
constexpr int kFleets = 3;
constexpr int kMissionsPerFleet = 6;

// A fleet whose missions each plan alone for `budget_ms` (a seed each, so
// no two share a goal tree) from the small city's start to its goal.
v1::FleetRequest Fleet(int fleet, int64_t budget_ms) {
  v1::FleetRequest r;
  for (int m = 0; m < kMissionsPerFleet; ++m) {
    v1::FleetMission* mission = r.add_missions();
    mission->set_id(absl::StrFormat("f%d-m%d", fleet, m));
    *mission->mutable_request() = SmallCityPlan(budget_ms);
    mission->mutable_request()->set_seed(100 * fleet + m + 1);
  }
  return r;
}

struct FleetRun {
  grpc::Status status;
  std::vector<v1::FleetUpdate> updates;
  std::vector<client::FleetResubmission> resubmissions;
};

// The number of fleet missions a replica holds (queued or planning), from
// its metrics; -1 when they cannot be read.
double MissionsOn(const ServerProcess& server) {
  absl::StatusOr<std::string> text = HttpGet(MetricsAddress(server.Stderr()), "/metrics");
  if (!text.ok()) return -1;
  return MetricValue(*text, "riskplan_fleet_missions{state=\"queued\"}").value_or(0) +
         MetricValue(*text, "riskplan_fleet_missions{state=\"running\"}").value_or(0);
}

TEST(ReplicasTest, AKilledAndADrainedReplicaLoseNoMissionAndNoEvaluateRiskCall) {
  std::vector<std::unique_ptr<ServerProcess>> servers;
  std::vector<std::string> addresses;
  for (int i = 0; i < kReplicas; ++i) {
    // One plan slot each, so a fleet's missions queue on its replica and
    // the fleet is still running when its replica goes.
    auto started = ServerProcess::Start({"--plan_threads=1", "--fleet_plan_slots=1",
                                         "--grace_period_ms=1500",
                                         "--metrics_listen=127.0.0.1:0"});
    ASSERT_TRUE(started.ok()) << started.status();
    servers.push_back(*std::move(started));
    addresses.push_back(servers.back()->address());
  }
  const std::string target = absl::StrJoin(addresses, ",");
  client::ConnectionOptions connection = servers[0]->connection();
  // A list has no one host for TLS to check the certificate against.
  if (connection.tls()) connection.tls_server_name = "localhost";
  absl::StatusOr<std::shared_ptr<grpc::Channel>> fleet_channel =
      client::MakeChannel(target, connection);
  ASSERT_TRUE(fleet_channel.ok()) << fleet_channel.status();
  absl::StatusOr<std::shared_ptr<grpc::Channel>> load_channel =
      client::MakeChannel(target, connection);
  ASSERT_TRUE(load_channel.ok()) << load_channel.status();
  client::RiskplanClient fleet_client(*fleet_channel);
  auto load = v1::Planner::NewStub(*load_channel);

  // Every replica connected on both channels: round-robin then goes over all
  // three in turn (a call's peer tells which one answered).
  for (auto* channel : {&*fleet_channel, &*load_channel}) {
    auto stub = v1::Planner::NewStub(*channel);
    std::set<std::string> peers;
    for (int attempt = 0; attempt < 300 && peers.size() < kReplicas; ++attempt) {
      grpc::ClientContext context;
      client::SetTimeout(&context, absl::Seconds(30));
      v1::PingResponse pong;
      if (stub->Ping(&context, v1::PingRequest(), &pong).ok()) peers.insert(context.peer());
    }
    ASSERT_EQ(peers.size(), static_cast<size_t>(kReplicas)) << "round-robin never reached all";
  }

  // The EvaluateRisk load: two callers until the fleets are done. Each call
  // is recorded with the replica that answered and when it began.
  struct Call {
    absl::Time began;
    grpc::Status status;
    std::string peer;
    double risk = 0;
  };
  absl::Mutex mu;
  std::vector<Call> calls;
  std::atomic<bool> stop{false};
  std::vector<std::thread> callers;
  for (int t = 0; t < 2; ++t) {
    callers.emplace_back([&] {
      while (!stop.load()) {
        Call call;
        call.began = absl::Now();
        grpc::ClientContext context;
        client::SetTimeout(&context, absl::Seconds(60));
        v1::EvaluateRiskResponse response;
        call.status = load->EvaluateRisk(&context, SmallCityPolyline(), &response);
        call.peer = context.peer();
        call.risk = response.risk();
        {
          absl::MutexLock lock(&mu);
          calls.push_back(std::move(call));
        }
        // A steady load rather than a flood: the replicas' CPU goes to the
        // fleets, whose missions are what the drill is about.
        absl::SleepFor(absl::Milliseconds(2));
      }
    });
  }

  // The fleets, started one after the other so that round-robin gives each
  // its own replica.
  std::vector<FleetRun> runs(kFleets);
  std::vector<std::thread> fleets;
  for (int f = 0; f < kFleets; ++f) {
    fleets.emplace_back([&, f] {
      FleetRun& run = runs[f];
      run.status = fleet_client.PlanFleet(
          Fleet(f, 700),
          [&](const v1::FleetUpdate& u) {
            run.updates.push_back(u);
            return true;
          },
          absl::Minutes(5),
          client::FleetResubmitOptions{
              .max_resubmits = 5,
              .on_resubmit = [&](const client::FleetResubmission& r) {
                run.resubmissions.push_back(r);
              }});
    });
  }

  // Mid-run: every replica holds fleet missions (each fleet has reached its
  // replica and none has ended), and the load has reached every replica.
  const absl::Time wait_until = absl::Now() + absl::Seconds(120);
  bool all_busy = false;
  std::map<std::string, int> before;
  while (!all_busy && absl::Now() < wait_until) {
    all_busy = true;
    for (const auto& s : servers) all_busy = all_busy && MissionsOn(*s) >= 2;
    {
      absl::MutexLock lock(&mu);
      before.clear();
      for (const Call& c : calls) ++before[c.peer];
    }
    all_busy = all_busy && before.size() == static_cast<size_t>(kReplicas);
    if (!all_busy) absl::SleepFor(absl::Milliseconds(20));
  }
  ASSERT_TRUE(all_busy) << "the fleets and the load did not reach all three replicas";

  servers[0]->Signal(SIGKILL);
  servers[1]->Signal(SIGTERM);
  EXPECT_FALSE(servers[0]->Wait(absl::Seconds(60)).has_value());  // died of the signal
  const std::optional<int> drained = servers[1]->Wait(absl::Seconds(60));
  ASSERT_TRUE(drained.has_value()) << "the SIGTERMed replica did not exit";
  EXPECT_EQ(*drained, 0);
  const absl::Time both_gone = absl::Now();

  for (std::thread& t : fleets) t.join();
  // Some load after both are gone, so that its balance can be seen.
  const auto calls_after = [&] {
    absl::MutexLock lock(&mu);
    int n = 0;
    for (const Call& c : calls) n += c.began > both_gone;
    return n;
  };
  while (calls_after() < 20) absl::SleepFor(absl::Milliseconds(10));
  stop = true;
  for (std::thread& t : callers) t.join();

  // Every mission of every fleet: exactly one final, with a trajectory.
  client::RiskplanClient survivor(servers[2]->Channel());
  int resubmitted_fleets = 0;
  for (int f = 0; f < kFleets; ++f) {
    const FleetRun& run = runs[f];
    ASSERT_TRUE(run.status.ok()) << "fleet " << f << ": " << run.status.error_message();
    resubmitted_fleets += !run.resubmissions.empty();
    std::map<int, int> finals;
    uint64_t sequence = 0;
    int ended = 0;
    for (const v1::FleetUpdate& u : run.updates) {
      // One stream to the caller, whatever happened underneath.
      EXPECT_EQ(u.sequence(), ++sequence);
      ASSERT_GE(u.mission_index(), 0);
      ASSERT_LT(u.mission_index(), kMissionsPerFleet);
      EXPECT_EQ(u.mission_id(), absl::StrFormat("f%d-m%d", f, u.mission_index()));
      ASSERT_EQ(u.error_code(), 0) << u.mission_id() << ": " << u.error_message();
      ASSERT_TRUE(u.update().final());
      EXPECT_EQ(u.missions_ended(), ++ended);
      ++finals[u.mission_index()];
      ASSERT_TRUE(u.update().has_trajectory()) << u.mission_id() << " ended "
                                               << v1::EndReason_Name(u.update().end_reason());
      v1::EvaluateRiskRequest eval;
      eval.set_map("demo-city");
      *eval.mutable_waypoints()->mutable_poses() = u.update().trajectory().waypoints();
      v1::EvaluateRiskResponse response;
      ASSERT_TRUE(survivor.EvaluateRisk(eval, &response).ok());
      EXPECT_EQ(response.risk(), u.update().trajectory().risk()) << u.mission_id();
    }
    EXPECT_EQ(finals.size(), static_cast<size_t>(kMissionsPerFleet)) << "fleet " << f;
    for (const auto& [index, count] : finals) EXPECT_EQ(count, 1) << "fleet " << f << " #" << index;
  }
  // The fleets of the killed and of the drained replica were re-submitted.
  EXPECT_GE(resubmitted_fleets, 2);

  // Every EvaluateRisk call succeeded, with the same answer; before the
  // signals the load was on all three replicas, after them on the survivor
  // alone.
  std::map<std::string, int> after;
  double risk = -1;
  for (const Call& c : calls) {
    ASSERT_TRUE(c.status.ok()) << c.peer << ": " << client::StatusCodeName(c.status.error_code())
                               << " " << c.status.error_message();
    if (risk < 0) risk = c.risk;
    EXPECT_EQ(c.risk, risk);
    if (c.began > both_gone) ++after[c.peer];
  }
  EXPECT_EQ(before.size(), static_cast<size_t>(kReplicas));
  ASSERT_EQ(after.size(), 1u);
  EXPECT_THAT(after.begin()->first, ::testing::HasSubstr(servers[2]->address()));
  std::printf("EvaluateRisk calls by replica before the signals:");
  for (const auto& [peer, n] : before) std::printf(" %s %d", peer.c_str(), n);
  std::printf("; after: %s %d; %zu calls in all, 0 failed\n", after.begin()->first.c_str(),
              after.begin()->second, calls.size());
  for (int f = 0; f < kFleets; ++f) {
    std::printf("fleet %d: %zu finals, %zu re-submissions", f, runs[f].updates.size(),
                runs[f].resubmissions.size());
    for (const client::FleetResubmission& r : runs[f].resubmissions) {
      std::printf(" [%d: %s, %d missions]", r.attempt,
                  client::StatusCodeName(r.broken.error_code()).c_str(), r.unfinished);
    }
    std::printf("\n");
  }
}

}  // namespace
}  // namespace riskplan::testing
