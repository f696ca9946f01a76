// PlanFleet against the real server: one final message per mission, a
// mission's own error beside the others' results, risks that are exactly
// EvaluateRisk's, the same trajectories for the same seed, a cancel that
// stops every mission, and the request's bounds.
#include <signal.h>

#include <map>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/clock.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/integration/requests.h"
#include "tests/integration/shared_server_test.h"

namespace riskplan::testing {
namespace {

// The last 4 kB of a server's stderr: its last log lines, or a sanitizer's
// report when it exited on one.
std::string StderrTail(const ServerProcess& server) {
  const std::string text = server.Stderr();
  const size_t from = text.size() > 4096 ? text.size() - 4096 : 0;
  return "\nserver stderr (last 4 kB):\n" + text.substr(from);
}

using ::testing::HasSubstr;

// Starts on the small city, admissible under the default parameters.
constexpr const char* kStarts[] = {kSmallCityStart, "400,300,245,0.785", "300,600,245,0.785"};

// A mission of the small city to its goal: RISK_RRT_STAR with `iterations`
// iterations only, so that it is reproducible.
v1::FleetMission Mission(const std::string& id, const char* start, int64_t iterations) {
  v1::FleetMission m;
  m.set_id(id);
  *m.mutable_request() = SmallCityPlan(0, iterations);
  *m.mutable_request()->mutable_start() = *client::ParsePose(start);
  return m;
}

// Three missions sharing one tree, one RRT mission on its own.
v1::FleetRequest MixedFleet() {
  v1::FleetRequest r;
  for (int i = 0; i < 3; ++i)
    *r.add_missions() = Mission(absl::StrFormat("tree-%d", i), kStarts[i], 300);
  v1::FleetMission rrt = Mission("rrt", kStarts[1], 300);
  rrt.mutable_request()->set_algorithm(v1::RRT);
  *r.add_missions() = rrt;
  return r;
}

struct FleetOutcome {
  grpc::Status status;
  std::vector<v1::FleetUpdate> updates;
  std::map<std::string, v1::FleetUpdate> finals;  // by mission id
  int finals_received = 0;
};

FleetOutcome RunFleet(client::RiskplanClient& client, const v1::FleetRequest& request) {
  FleetOutcome out;
  out.status = client.PlanFleet(request, [&](const v1::FleetUpdate& u) {
    out.updates.push_back(u);
    if (u.error_code() != 0 || u.update().final()) {
      ++out.finals_received;
      out.finals[u.mission_id()] = u;
    }
    return true;
  });
  return out;
}

// A gauge or counter of `server`'s metrics; -1 when it cannot be read.
double ServerMetric(const ServerProcess& server, const std::string& series) {
  absl::StatusOr<std::string> text = HttpGet(MetricsAddress(server.Stderr()), "/metrics");
  if (!text.ok()) return -1;
  return MetricValue(*text, series).value_or(-1);
}

// Every trajectory `out` reported (improvements and finals, at least 4) has
// exactly EvaluateRisk's risk and length.
void ExpectRisksAreEvaluateRisks(client::RiskplanClient& client, const FleetOutcome& out) {
  int checked = 0;
  for (const v1::FleetUpdate& u : out.updates) {
    if (!u.update().has_trajectory()) continue;
    v1::EvaluateRiskRequest eval;
    eval.set_map("demo-city");
    *eval.mutable_waypoints()->mutable_poses() = u.update().trajectory().waypoints();
    v1::EvaluateRiskResponse response;
    ASSERT_TRUE(client.EvaluateRisk(eval, &response).ok());
    EXPECT_EQ(response.risk(), u.update().trajectory().risk()) << u.mission_id();
    EXPECT_EQ(response.length_m(), u.update().trajectory().length_m()) << u.mission_id();
    ++checked;
  }
  EXPECT_GE(checked, 4);
}

class FleetTest : public SharedServerTest<FleetTest> {
 public:
  static std::vector<std::string> ServerFlags() {
    return {"--plan_threads=2", "--max_fleet_missions=8", "--metrics_listen=127.0.0.1:0"};
  }

 protected:
  // A gauge or counter of the server's metrics; -1 when it cannot be read.
  double Metric(const std::string& series) { return ServerMetric(*server_, series); }
};

TEST_F(FleetTest, EveryMissionGetsExactlyOneFinalMessageTaggedWithItsId) {
  FleetOutcome out = RunFleet(*client_, MixedFleet());
  ASSERT_TRUE(out.status.ok()) << out.status.error_message();
  EXPECT_EQ(out.finals_received, 4);
  ASSERT_EQ(out.finals.size(), 4u);
  int ended = 0;
  uint64_t sequence = 0;
  for (const v1::FleetUpdate& u : out.updates) {
    EXPECT_EQ(u.sequence(), ++sequence);
    // Without send_improvements, only final messages, in completion order.
    ASSERT_TRUE(u.update().final()) << u.mission_id();
    EXPECT_EQ(u.missions_ended(), ++ended);
    EXPECT_EQ(u.error_code(), 0) << u.error_message();
    EXPECT_TRUE(u.update().has_trajectory()) << u.mission_id();
    // RRT ends at its first trajectory; the tree's missions at their budget.
    EXPECT_EQ(u.update().end_reason(),
              u.mission_id() == "rrt" ? v1::CONVERGED : v1::BUDGET_EXHAUSTED)
        << u.mission_id();
  }
  for (int i = 0; i < 3; ++i) {
    const v1::FleetUpdate& u = out.finals.at(absl::StrFormat("tree-%d", i));
    EXPECT_EQ(u.mission_index(), i);
    // Each trajectory starts at its own mission's start.
    const v1::Pose start = *client::ParsePose(kStarts[i]);
    EXPECT_EQ(u.update().trajectory().waypoints(0).x(), start.x());
    EXPECT_EQ(u.update().trajectory().waypoints(0).y(), start.y());
  }
  EXPECT_EQ(out.finals.at("rrt").mission_index(), 3);
}

TEST_F(FleetTest, EveryReportedRiskIsEvaluateRisksBitForBit) {
  v1::FleetRequest request = MixedFleet();
  request.set_send_improvements(true);
  FleetOutcome out = RunFleet(*client_, request);
  ASSERT_TRUE(out.status.ok()) << out.status.error_message();
  ExpectRisksAreEvaluateRisks(*client_, out);
}

TEST_F(FleetTest, SameFleetAndSeedGiveTheSameTrajectories) {
  FleetOutcome a = RunFleet(*client_, MixedFleet());
  FleetOutcome b = RunFleet(*client_, MixedFleet());
  ASSERT_TRUE(a.status.ok() && b.status.ok());
  ASSERT_EQ(a.finals.size(), 4u);
  for (const auto& [id, u] : a.finals) {
    const v1::Trajectory& ta = u.update().trajectory();
    const v1::Trajectory& tb = b.finals.at(id).update().trajectory();
    EXPECT_EQ(ta.risk(), tb.risk()) << id;
    ASSERT_EQ(ta.waypoints_size(), tb.waypoints_size()) << id;
    for (int k = 0; k < ta.waypoints_size(); ++k) {
      EXPECT_EQ(ta.waypoints(k).SerializeAsString(), tb.waypoints(k).SerializeAsString()) << id;
    }
  }
  // Another seed grows another tree.
  v1::FleetRequest other = MixedFleet();
  for (v1::FleetMission& m : *other.mutable_missions()) m.mutable_request()->set_seed(8);
  FleetOutcome c = RunFleet(*client_, other);
  ASSERT_TRUE(c.status.ok());
  EXPECT_NE(c.finals.at("tree-0").update().trajectory().SerializeAsString(),
            a.finals.at("tree-0").update().trajectory().SerializeAsString());
}

TEST_F(FleetTest, AnInvalidMissionGetsItsOwnErrorWhileTheOthersArePlanned) {
  v1::FleetRequest request = MixedFleet();
  // Outside the 2 km map: refused by validation.
  request.mutable_missions(1)->mutable_request()->mutable_start()->set_x(5000);
  // Inside the map but under the terrain: refused when planned.
  request.mutable_missions(3)->mutable_request()->mutable_start()->set_z(-50);
  FleetOutcome out = RunFleet(*client_, request);
  ASSERT_TRUE(out.status.ok()) << out.status.error_message();
  ASSERT_EQ(out.finals.size(), 4u);
  const v1::FleetUpdate& outside = out.finals.at("tree-1");
  EXPECT_EQ(outside.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(outside.error_message(),
              HasSubstr("missions[1].request.start (x, y) = (5000, 300) is outside map"));
  EXPECT_FALSE(outside.has_update());
  const v1::FleetUpdate& buried = out.finals.at("rrt");
  EXPECT_EQ(buried.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(buried.error_message(), HasSubstr("missions[3].request.start pose"));
  for (const char* id : {"tree-0", "tree-2"}) {
    EXPECT_EQ(out.finals.at(id).error_code(), 0) << out.finals.at(id).error_message();
    EXPECT_TRUE(out.finals.at(id).update().has_trajectory()) << id;
  }
}

TEST_F(FleetTest, ARequestOverTheLimitIsRefusedNamingIt) {
  v1::FleetRequest request;
  for (int i = 0; i < 9; ++i)
    *request.add_missions() = Mission(absl::StrFormat("m%d", i), kStarts[0], 10);
  FleetOutcome out = RunFleet(*client_, request);
  EXPECT_EQ(out.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(out.status.error_message(),
            "missions has 9 missions; it must have 1 to 8 (--max_fleet_missions)");
  EXPECT_TRUE(out.updates.empty());
  // Ids are the fleet's structure: a repeated one refuses the whole request.
  v1::FleetRequest twice;
  *twice.add_missions() = Mission("same", kStarts[0], 10);
  *twice.add_missions() = Mission("same", kStarts[1], 10);
  out = RunFleet(*client_, twice);
  EXPECT_EQ(out.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(out.status.error_message(), HasSubstr("missions[1].id 'same'"));
}

TEST_F(FleetTest, CancellingTheCallStopsEveryMission) {
  // Missions that only a cancel can end (the server's cap of ten minutes).
  v1::FleetRequest request;
  for (int i = 0; i < 3; ++i) {
    v1::FleetMission m = Mission(absl::StrFormat("endless-%d", i), kStarts[i], 0);
    m.mutable_request()->mutable_budget()->set_time_ms(600000);
    m.mutable_request()->mutable_goal()->set_z(250 + i);  // three goals: three groups
    *request.add_missions() = m;
  }
  grpc::ClientContext context;
  std::unique_ptr<grpc::ClientReader<v1::FleetUpdate>> reader =
      client_->stub().PlanFleet(&context, request);
  // Planning: two groups hold the two planning threads.
  const absl::Time start = absl::Now();
  while (Metric("riskplan_running_plans") < 2 && absl::Now() - start < absl::Seconds(60)) {
    absl::SleepFor(absl::Milliseconds(20));
  }
  ASSERT_EQ(Metric("riskplan_running_plans"), 2);
  EXPECT_EQ(Metric("riskplan_fleet_missions{state=\"queued\"}"), 1);
  context.TryCancel();
  v1::FleetUpdate update;
  while (reader->Read(&update)) {
  }
  EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::CANCELLED);
  // Every planner stops and every slot comes back.
  while ((Metric("riskplan_running_plans") != 0 ||
          Metric("riskplan_fleet_missions{state=\"running\"}") != 0) &&
         absl::Now() - start < absl::Seconds(60)) {
    absl::SleepFor(absl::Milliseconds(20));
  }
  EXPECT_EQ(Metric("riskplan_running_plans"), 0);
  EXPECT_EQ(Metric("riskplan_fleet_missions{state=\"running\"}"), 0);
  EXPECT_EQ(Metric("riskplan_fleet_missions{state=\"queued\"}"), 0);
  // And the server plans the next fleet.
  EXPECT_TRUE(RunFleet(*client_, MixedFleet()).status.ok());
}

// One plan slot, and room for five admitted missions: the queue's order and
// the admission by missions can be seen from the outside.
class FleetFairShareTest : public SharedServerTest<FleetFairShareTest> {
 public:
  static std::vector<std::string> ServerFlags() {
    return {"--plan_threads=1", "--max_fleet_missions=4", "--max_admitted_missions=5",
            "--metrics_listen=127.0.0.1:0"};
  }

 protected:
  double Metric(const std::string& series) { return ServerMetric(*server_, series); }
  // Polls until the metric has `value` (or a minute has passed).
  void AwaitMetric(const std::string& series, double value) {
    const absl::Time start = absl::Now();
    while (Metric(series) != value && absl::Now() - start < absl::Seconds(60)) {
      absl::SleepFor(absl::Milliseconds(5));
    }
  }
};

// `n` missions of `tenant`, each to its own goal (a group each), at
// `priority`.
v1::FleetRequest TenantFleet(const std::string& tenant, int n, int priority) {
  v1::FleetRequest r;
  r.set_tenant(tenant);
  for (int i = 0; i < n; ++i) {
    v1::FleetMission m = Mission(absl::StrFormat("%s-%d", tenant, i), kStarts[i % 3], 300);
    m.set_priority(priority);
    m.mutable_request()->mutable_goal()->set_z(250 + i);
    *r.add_missions() = m;
  }
  return r;
}

// The order is decided while every mission waits, so it depends on no timing:
// a blocker holds the one slot until every fleet is queued, then its call is
// cancelled and the queue alone decides.
TEST_F(FleetFairShareTest, ATenantArrivingLaterGetsTheNextSlotAndAdmissionCountsMissions) {
  absl::Mutex mu;
  std::vector<std::string> ended;  // mission ids, in the order their finals arrived
  const auto run = [&](const v1::FleetRequest& request) {
    client::RiskplanClient c(server_->Channel());
    return c.PlanFleet(request, [&](const v1::FleetUpdate& u) {
      absl::MutexLock lock(&mu);
      ended.push_back(u.mission_id());
      return true;
    });
  };
  // The blocker: one mission that only a cancel ends.
  v1::FleetRequest blocker = TenantFleet("blocker", 1, 0);
  blocker.mutable_missions(0)->mutable_request()->mutable_budget()->set_time_ms(600000);
  client::RiskplanClient blocker_client(server_->Channel());
  grpc::ClientContext blocker_context;
  std::unique_ptr<grpc::ClientReader<v1::FleetUpdate>> blocker_reader =
      blocker_client.stub().PlanFleet(&blocker_context, blocker);
  AwaitMetric("riskplan_fleet_missions{state=\"running\"}", 1);
  ASSERT_EQ(Metric("riskplan_fleet_missions{state=\"running\"}"), 1);
  // "big" queues three groups at the highest priority.
  grpc::Status big_status;
  std::thread big([&] { big_status = run(TenantFleet("big", 3, 1000)); });
  AwaitMetric("riskplan_fleet_missions{state=\"queued\"}", 3);
  ASSERT_EQ(Metric("riskplan_fleet_missions{state=\"queued\"}"), 3);
  // Four of five admitted missions: a fleet of two does not fit, and is
  // refused at once, whole.
  const grpc::Status refused = run(TenantFleet("other", 2, 0));
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(refused.error_message(),
              HasSubstr("cannot admit this fleet's 2 missions: at most 5 fleet missions are "
                        "admitted at once (--max_admitted_missions)"));
  // "small" queues one mission at priority 0.
  grpc::Status small_status;
  std::thread small([&] { small_status = run(TenantFleet("small", 1, 0)); });
  AwaitMetric("riskplan_fleet_missions{state=\"queued\"}", 4);
  ASSERT_EQ(Metric("riskplan_fleet_missions{state=\"queued\"}"), 4);
  blocker_context.TryCancel();
  v1::FleetUpdate update;
  while (blocker_reader->Read(&update)) {
  }
  EXPECT_EQ(blocker_reader->Finish().error_code(), grpc::StatusCode::CANCELLED);
  big.join();
  small.join();
  ASSERT_TRUE(big_status.ok()) << big_status.error_message();
  ASSERT_TRUE(small_status.ok()) << small_status.error_message();
  if (server_->connection().token_file.empty()) {
    // Two tenants, neither has planned: big's priority takes the slot; then
    // small is owed a turn, which big's priority cannot take from it.
    EXPECT_THAT(ended, ::testing::ElementsAre("big-0", "small-0", "big-1", "big-2"));
  } else {
    // RISKPLAN_TEST_SECURITY=tls: every client has the suite's one token, so
    // there is one caller, the tenant field is ignored, and priority alone
    // orders its groups (docs/fleet.md).
    EXPECT_THAT(ended, ::testing::ElementsAre("big-0", "big-1", "big-2", "small-0"));
  }
  EXPECT_EQ(Metric("riskplan_fleet_missions_admitted_total"), 5);
}

// Two missions with ten-minute budgets and goals of their own (two groups):
// with one plan slot, the first plans and the second waits.
v1::FleetRequest EndlessFleet() {
  v1::FleetRequest request;
  for (int i = 0; i < 2; ++i) {
    v1::FleetMission m = Mission(absl::StrFormat("endless-%d", i), kStarts[i], 0);
    m.mutable_request()->mutable_budget()->set_time_ms(600000);
    m.mutable_request()->mutable_goal()->set_z(250 + i);
    *request.add_missions() = m;
  }
  request.set_send_improvements(true);
  return request;
}

// Runs `request` on `server` and SIGTERMs the server at the first update (the
// first mission's first improvement: it plans); the finals passed on.
grpc::Status PlanFleetAndDrain(ServerProcess& server, const v1::FleetRequest& request,
                               const client::FleetResubmitOptions& resubmit,
                               std::vector<v1::FleetUpdate>* finals) {
  client::RiskplanClient client(server.Channel());
  bool signalled = false;
  return client.PlanFleet(
      request,
      [&](const v1::FleetUpdate& u) {
        if (!signalled) {
          server.Signal(SIGTERM);
          signalled = true;
        }
        if (u.update().final()) finals->push_back(u);
        return true;
      },
      absl::InfiniteDuration(), resubmit);
}

TEST(FleetShutdownTest, EveryMissionEndsWithShutdownAndTheServerExits) {
  absl::StatusOr<std::unique_ptr<ServerProcess>> server =
      ServerProcess::Start({"--plan_threads=1", "--grace_period_ms=1000"});
  ASSERT_TRUE(server.ok()) << server.status();
  // The server's own finals, not re-submitted (the client's re-submission:
  // replicas_test.cc and the test below).
  std::vector<v1::FleetUpdate> finals;
  client::FleetResubmitOptions no_resubmits;
  no_resubmits.max_resubmits = 0;
  const grpc::Status status = PlanFleetAndDrain(**server, EndlessFleet(), no_resubmits, &finals);
  EXPECT_TRUE(status.ok()) << status.error_message();
  ASSERT_EQ(finals.size(), 2u);
  // The waiting one ends at once, unplanned; the planning one at the end of
  // the grace period, with its best trajectory.
  EXPECT_EQ(finals[0].mission_id(), "endless-1");
  EXPECT_FALSE(finals[0].update().has_trajectory());
  EXPECT_EQ(finals[1].mission_id(), "endless-0");
  EXPECT_TRUE(finals[1].update().has_trajectory());
  for (const v1::FleetUpdate& u : finals) EXPECT_EQ(u.update().end_reason(), v1::SHUTDOWN);
  // On another exit, what the server (or a sanitizer) said last.
  EXPECT_EQ((*server)->Wait(absl::Seconds(60)), 0) << StderrTail(**server);
}

TEST(FleetShutdownTest, AMissionTheDrainLeftUnplannedKeepsThatFinalWhenNoReplicaIsLeft) {
  absl::StatusOr<std::unique_ptr<ServerProcess>> server =
      ServerProcess::Start({"--plan_threads=1", "--grace_period_ms=1000"});
  ASSERT_TRUE(server.ok()) << server.status();
  std::vector<v1::FleetUpdate> finals;
  std::vector<client::FleetResubmission> resubmissions;
  const grpc::Status status = PlanFleetAndDrain(
      **server, EndlessFleet(),
      client::FleetResubmitOptions{
          .max_resubmits = 2,
          .backoff = absl::Milliseconds(50),
          .on_resubmit = [&](const client::FleetResubmission& r) { resubmissions.push_back(r); }},
      &finals);
  // The drain's call ended OK with endless-1 unplanned: sent again, to the
  // one address there is, which is gone by then (or refuses it while it
  // drains), twice.
  ASSERT_EQ(resubmissions.size(), 2u);
  EXPECT_EQ(resubmissions[0].attempt, 1);
  EXPECT_TRUE(resubmissions[0].broken.ok());
  EXPECT_EQ(resubmissions[0].unfinished, 1);
  EXPECT_EQ(resubmissions[1].attempt, 2);
  EXPECT_EQ(resubmissions[1].broken.error_code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE);
  // Each mission still has exactly one final: the planned one's, then the
  // drain's unplanned one, held back until no re-submission was left.
  ASSERT_EQ(finals.size(), 2u);
  EXPECT_EQ(finals[0].mission_id(), "endless-0");
  EXPECT_TRUE(finals[0].update().has_trajectory());
  EXPECT_EQ(finals[1].mission_id(), "endless-1");
  EXPECT_EQ(finals[1].mission_index(), 1);
  EXPECT_FALSE(finals[1].update().has_trajectory());
  EXPECT_EQ(finals[1].missions_ended(), 2);
  for (const v1::FleetUpdate& u : finals) EXPECT_EQ(u.update().end_reason(), v1::SHUTDOWN);
  // On another exit, what the server (or a sanitizer) said last.
  EXPECT_EQ((*server)->Wait(absl::Seconds(60)), 0) << StderrTail(**server);
}

// The goal tree cache (--goal_tree_cache_mb): a fleet to a goal a fleet
// already planned begins from the grown tree.
class FleetGoalTreeCacheTest : public SharedServerTest<FleetGoalTreeCacheTest> {
 public:
  static std::vector<std::string> ServerFlags() {
    return {"--plan_threads=2", "--max_fleet_missions=8", "--goal_tree_cache_mb=64",
            "--metrics_listen=127.0.0.1:0"};
  }

 protected:
  double Metric(const std::string& series) { return ServerMetric(*server_, series); }
};

TEST_F(FleetGoalTreeCacheTest, TheSameFleetTwiceHitsAndEveryRiskIsEvaluateRisks) {
  v1::FleetRequest request = MixedFleet();
  request.set_send_improvements(true);
  EXPECT_EQ(Metric("riskplan_goal_tree_cache_limit_bytes"), 64.0 * 1024 * 1024);
  const double hits = Metric("riskplan_goal_tree_cache_hits_total");
  const double misses = Metric("riskplan_goal_tree_cache_misses_total");
  ASSERT_GE(hits, 0);
  ASSERT_GE(misses, 0);

  FleetOutcome first = RunFleet(*client_, request);
  ASSERT_TRUE(first.status.ok()) << first.status.error_message();
  // The three tree missions are one shared group: one look-up, a miss; the
  // RRT mission plans alone and never looks.
  EXPECT_EQ(Metric("riskplan_goal_tree_cache_misses_total"), misses + 1);
  EXPECT_EQ(Metric("riskplan_goal_tree_cache_hits_total"), hits);
  EXPECT_GE(Metric("riskplan_goal_tree_cache_entries"), 1);
  EXPECT_GT(Metric("riskplan_goal_tree_cache_bytes"), 0);
  ExpectRisksAreEvaluateRisks(*client_, first);

  FleetOutcome second = RunFleet(*client_, request);
  ASSERT_TRUE(second.status.ok()) << second.status.error_message();
  EXPECT_EQ(Metric("riskplan_goal_tree_cache_hits_total"), hits + 1);
  EXPECT_EQ(Metric("riskplan_goal_tree_cache_misses_total"), misses + 1);
  ExpectRisksAreEvaluateRisks(*client_, second);
  ASSERT_EQ(second.finals.size(), 4u);
  for (int i = 0; i < 3; ++i) {
    const v1::FleetUpdate& u = second.finals.at(absl::StrFormat("tree-%d", i));
    EXPECT_EQ(u.error_code(), 0) << u.error_message();
    EXPECT_TRUE(u.update().has_trajectory());
  }
}

// Without the flag no tree outlives its request: two identical fleets give
// identical trajectories, and the cache's metrics stay at 0.
TEST_F(FleetTest, WithoutTheGoalTreeCacheIdenticalFleetsGiveIdenticalTrajectories) {
  FleetOutcome a = RunFleet(*client_, MixedFleet());
  FleetOutcome b = RunFleet(*client_, MixedFleet());
  ASSERT_TRUE(a.status.ok() && b.status.ok());
  ASSERT_EQ(a.finals.size(), 4u);
  for (const auto& [id, u] : a.finals) {
    // Everything but found_at_s, the wall time that found it.
    v1::Trajectory ta = u.update().trajectory();
    v1::Trajectory tb = b.finals.at(id).update().trajectory();
    ta.clear_found_at_s();
    tb.clear_found_at_s();
    EXPECT_EQ(ta.SerializeAsString(), tb.SerializeAsString()) << id;
  }
  EXPECT_EQ(Metric("riskplan_goal_tree_cache_hits_total"), 0);
  EXPECT_EQ(Metric("riskplan_goal_tree_cache_misses_total"), 0);
  EXPECT_EQ(Metric("riskplan_goal_tree_cache_entries"), 0);
  EXPECT_EQ(Metric("riskplan_goal_tree_cache_limit_bytes"), 0);
}

TEST(FleetGoalTreeCacheFlagTest, AnOutOfRangeSizeIsRefusedAtStartUp) {
  const std::string binary = absl::StrCat(RISKPLAN_BIN_DIR, "/riskplan-server");
  const CommandResult help = RunCommand(binary + " --help 2>&1");
  EXPECT_THAT(help.output, HasSubstr("-goal_tree_cache_mb"));
  for (const char* value : {"-1", "65537"}) {
    const CommandResult r = RunCommand(
        absl::StrFormat("%s --listen=127.0.0.1:0 --goal_tree_cache_mb=%s 2>&1", binary, value));
    EXPECT_EQ(r.exit_code, 2) << value;
    EXPECT_THAT(r.output, HasSubstr("need 0 <= --goal_tree_cache_mb <= 65536")) << value;
  }
}

}  // namespace
}  // namespace riskplan::testing
