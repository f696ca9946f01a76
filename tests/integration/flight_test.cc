// Fly, the in-flight session, through the real server and a real client
// stream: the commit rule under progress alone, a zone ahead and its removal,
// a zone over the aircraft, a wind change, a stream broken and resumed on
// another server, and inputs refused with the session alive. Every plan
// version's route risk is checked against EvaluateRisk, bit for bit.
#include <signal.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "gtest/gtest.h"
#include "riskplan/v1/planner.grpc.pb.h"
#include "tests/child_process.h"
#include "tests/integration/requests.h"
#include "tests/integration/server_process.h"
#include "tests/integration/shared_server_test.h"

namespace riskplan::testing {
namespace {

constexpr double kHorizonS = 10.0;
constexpr int64_t kReplanMs = 300;
constexpr double kAirspeed = 18.0;  // the default model's

// One Fly stream on the sync API: write an input, read outputs.
class FlightStream {
 public:
  explicit FlightStream(const std::shared_ptr<grpc::Channel>& channel)
      : stub_(v1::Planner::NewStub(channel)) {
    ctx_.set_deadline(std::chrono::system_clock::now() + std::chrono::minutes(5));
    stream_ = stub_->Fly(&ctx_);
  }
  bool Write(const v1::FlightInput& in) { return stream_->Write(in); }
  std::optional<v1::FlightOutput> Read() {
    v1::FlightOutput out;
    if (!stream_->Read(&out)) return std::nullopt;
    return out;
  }
  // The next output but IMPROVED versions, which are checked and collected
  // in `improved`: a change's first version goes out as soon as it exists,
  // and an IMPROVED one follows, from the same commit point, when the plan
  // then finds a remainder of less risk.
  std::optional<v1::FlightOutput> ReadChange() {
    while (std::optional<v1::FlightOutput> o = Read()) {
      if (!o->has_plan()) return o;
      if (o->plan().reason() == v1::FLIGHT_REASON_IMPROVED) {
        EXPECT_TRUE(last_plan.has_value());
        if (last_plan.has_value()) {
          EXPECT_EQ(o->plan().committed_until_m(), last_plan->committed_until_m());
          EXPECT_EQ(o->plan().committed_size(), last_plan->committed_size());
          EXPECT_LT(o->plan().remainder().risk(), last_plan->remainder().risk());
        }
        improved.push_back(o->plan());
        last_plan = o->plan();
        continue;
      }
      last_plan = o->plan();
      return o;
    }
    return std::nullopt;
  }
  // The next plan version or alert (refusals are collected on the way).
  std::optional<v1::FlightOutput> NextPlanOrAlert() {
    while (std::optional<v1::FlightOutput> o = ReadChange()) {
      if (o->has_refusal()) {
        refusals.push_back(o->refusal());
        continue;
      }
      return o;
    }
    return std::nullopt;
  }
  std::optional<v1::FlightRefusal> NextRefusal() {
    std::optional<v1::FlightOutput> o = ReadChange();
    if (!o.has_value() || !o->has_refusal()) return std::nullopt;
    return o->refusal();
  }
  // The version in force before `v` (the last IMPROVED one after `before`, or `before`).
  v1::FlightPlanVersion InForceBefore(const v1::FlightPlanVersion& before,
                                      const v1::FlightPlanVersion& v) const {
    v1::FlightPlanVersion in_force = before;
    for (const v1::FlightPlanVersion& i : improved) {
      if (i.version() > in_force.version() && i.version() < v.version()) in_force = i;
    }
    return in_force;
  }
  // Sends `end`, half-closes and reads every output left; the status.
  grpc::Status End(std::vector<v1::FlightOutput>* rest = nullptr) {
    v1::FlightInput end;
    end.mutable_end();
    stream_->Write(end);
    stream_->WritesDone();
    while (std::optional<v1::FlightOutput> o = ReadChange()) {
      if (rest != nullptr) rest->push_back(*o);
    }
    return stream_->Finish();
  }
  void Cancel() { ctx_.TryCancel(); }

  std::vector<v1::FlightRefusal> refusals;
  std::vector<v1::FlightPlanVersion> improved;
  std::optional<v1::FlightPlanVersion> last_plan;

 private:
  std::unique_ptr<v1::Planner::Stub> stub_;
  grpc::ClientContext ctx_;
  std::unique_ptr<grpc::ClientReaderWriter<v1::FlightInput, v1::FlightOutput>> stream_;
};

v1::FlightInput Open(int64_t budget_ms = 1000) {
  v1::FlightInput in;
  v1::FlightOpen* open = in.mutable_open();
  *open->mutable_plan() = SmallCityPlan(budget_ms);
  open->set_commit_horizon_s(kHorizonS);
  open->mutable_replan_budget()->set_time_ms(kReplanMs);
  return in;
}

v1::FlightInput Progress(double t, double progress_m) {
  v1::FlightInput in;
  in.mutable_position()->set_time_s(t);
  in.mutable_position()->set_progress_m(progress_m);
  return in;
}

v1::FlightInput Circle(const std::string& id, double x, double y, double r) {
  v1::FlightInput in;
  v1::FlightZone* z = in.mutable_add_zone();
  z->set_id(id);
  z->mutable_circle()->set_x(x);
  z->mutable_circle()->set_y(y);
  z->mutable_circle()->set_radius_m(r);
  return in;
}

v1::FlightInput Remove(const std::string& id) {
  v1::FlightInput in;
  in.mutable_remove_zone()->set_id(id);
  return in;
}

// The horizon's distance: (N + replanning budget) x (airspeed + wind).
double HorizonM(double wind = 0.0) { return (kHorizonS + kReplanMs / 1000.0) * (kAirspeed + wind); }

bool SamePose(const v1::Pose& a, const v1::Pose& b) {
  return a.x() == b.x() && a.y() == b.y() && a.z() == b.z() && a.theta() == b.theta();
}

// EvaluateRisk of the version's route gives exactly its risk, length and
// flight time; the route is admissible.
void ExpectEvaluateRiskAgrees(client::RiskplanClient& client, const v1::FlightPlanVersion& v,
                              const v1::ModelParameters& params = {}) {
  if (v.route().waypoints_size() < 2) return;
  v1::EvaluateRiskRequest request;
  request.set_map("demo-city");
  *request.mutable_model_params() = params;
  *request.mutable_waypoints()->mutable_poses() = v.route().waypoints();
  v1::EvaluateRiskResponse response;
  ASSERT_TRUE(client.EvaluateRisk(request, &response).ok());
  EXPECT_TRUE(response.admissible()) << "version " << v.version();
  EXPECT_EQ(response.risk(), v.route().risk()) << "version " << v.version();
  EXPECT_EQ(response.length_m(), v.route().length_m()) << "version " << v.version();
}

// The arc length where the route's display path first comes within `d` of (x, y); -1 if never.
bool PathEnters(const v1::Trajectory& t, double x, double y, double r) {
  for (const v1::Pose& p : t.path()) {
    if (std::hypot(p.x() - x, p.y() - y) <= r) return true;
  }
  return false;
}

void ExpectCommittedExtends(const v1::FlightPlanVersion& before, const v1::FlightPlanVersion& after) {
  ASSERT_GE(after.committed_size(), before.committed_size());
  for (int k = 0; k < before.committed_size(); ++k) {
    EXPECT_TRUE(SamePose(before.committed(k), after.committed(k)))
        << "version " << after.version() << " changed committed pose " << k;
  }
}

class FlightTest : public SharedServerTest<FlightTest> {
 protected:
  std::unique_ptr<FlightStream> Stream() { return std::make_unique<FlightStream>(server_->Channel()); }
};

TEST_F(FlightTest, ProgressAloneNeverChangesThePrefixNorSendsARemainderBehindTheAircraft) {
  auto s = Stream();
  ASSERT_TRUE(s->Write(Open()));
  std::optional<v1::FlightOutput> first = s->NextPlanOrAlert();
  ASSERT_TRUE(first.has_value() && first->has_plan());
  const v1::FlightPlanVersion v1 = first->plan();
  EXPECT_EQ(v1.version(), 1u);
  EXPECT_EQ(v1.reason(), v1::FLIGHT_REASON_OPENED);
  EXPECT_GE(v1.committed_until_m(), HorizonM());
  ExpectEvaluateRiskAgrees(*client_, v1);
  const double length = v1.route().length_m();
  // Fly the route at the airspeed, one report a second.
  for (double t = 1.0; kAirspeed * t < length; t += 1.0) {
    ASSERT_TRUE(s->Write(Progress(t, kAirspeed * t)));
  }
  std::vector<v1::FlightOutput> rest;
  ASSERT_TRUE(s->End(&rest).ok());
  v1::FlightPlanVersion last = v1;
  int versions = 0;
  for (const v1::FlightOutput& o : rest) {
    ASSERT_TRUE(o.has_plan()) << o.DebugString();
    const v1::FlightPlanVersion& v = o.plan();
    ++versions;
    EXPECT_EQ(v.version(), last.version() + 1);
    EXPECT_EQ(v.reason(), v1::FLIGHT_REASON_PROGRESS);
    ExpectCommittedExtends(last, v);
    // The remainder starts at the commit point, which is ahead of the aircraft by the horizon
    // (or at the goal).
    EXPECT_TRUE(SamePose(v.remainder().waypoints(0), v.committed(v.committed_size() - 1)));
    EXPECT_GE(v.committed_until_m(), v.progress_m());
    if (v.remainder().waypoints_size() > 1) {
      EXPECT_GE(v.committed_until_m() + 1e-6, v.progress_m() + HorizonM());
    }
    // The aircraft flies the same route: the route's length from the aircraft's
    // waypoint never exceeds what it was.
    EXPECT_LE(v.route().length_m(), last.route().length_m() + 1e-6);
    if (versions % 5 == 1) ExpectEvaluateRiskAgrees(*client_, v);
    last = v;
  }
  EXPECT_GE(versions, 3);
}

TEST_F(FlightTest, AZoneAheadGivesAnAdmissibleRouteRoundItAndItsRemovalLetsTheRouteBack) {
  auto s = Stream();
  ASSERT_TRUE(s->Write(Open()));
  std::optional<v1::FlightOutput> first = s->NextPlanOrAlert();
  ASSERT_TRUE(first.has_value() && first->has_plan());
  const v1::FlightPlanVersion v1 = first->plan();
  // A fire 1 km ahead, across the route.
  const v1::Trajectory& route = v1.route();
  const double step = route.length_m() / (route.path_size() - 1);
  const v1::Pose& ahead = route.path(static_cast<int>(std::lround(1000.0 / step)));
  const double radius = 150.0;
  ASSERT_TRUE(s->Write(Circle("fire", ahead.x(), ahead.y(), radius)));
  std::optional<v1::FlightOutput> second = s->NextPlanOrAlert();
  ASSERT_TRUE(second.has_value());
  ASSERT_TRUE(second->has_plan()) << second->DebugString();
  const v1::FlightPlanVersion v2 = second->plan();
  EXPECT_EQ(v2.version(), 2u);
  EXPECT_EQ(v2.reason(), v1::FLIGHT_REASON_ZONE_ADDED);
  ASSERT_EQ(v2.active_zones_size(), 1);
  EXPECT_EQ(v2.active_zones(0), "fire");
  // The prefix is intact, and the route keeps out of the zone.
  ASSERT_EQ(v2.committed_size(), v1.committed_size());
  ExpectCommittedExtends(v1, v2);
  EXPECT_FALSE(PathEnters(v2.route(), ahead.x(), ahead.y(), radius));
  ExpectEvaluateRiskAgrees(*client_, v2);

  ASSERT_TRUE(s->Write(Remove("fire")));
  std::optional<v1::FlightOutput> third = s->NextPlanOrAlert();
  ASSERT_TRUE(third.has_value() && third->has_plan()) << third->DebugString();
  const v1::FlightPlanVersion v3 = third->plan();
  EXPECT_EQ(v3.reason(), v1::FLIGHT_REASON_ZONE_REMOVED);
  EXPECT_EQ(v3.active_zones_size(), 0);
  ExpectCommittedExtends(v1, v3);
  ExpectEvaluateRiskAgrees(*client_, v3);
  // The route comes back: the remainders of both earlier versions are candidates again, so
  // the new one is no riskier than either, and when the first was the better it is back
  // through the area the zone closed. (v2 as its IMPROVED versions left it.)
  for (const v1::FlightPlanVersion& i : s->improved) {
    EXPECT_FALSE(PathEnters(i.route(), ahead.x(), ahead.y(), radius)) << i.version();
    ExpectEvaluateRiskAgrees(*client_, i);
  }
  const v1::FlightPlanVersion v2_in_force = s->InForceBefore(v2, v3);
  EXPECT_LE(v3.route().risk(), v2_in_force.route().risk());
  EXPECT_LE(v3.route().risk(), v1.route().risk());
  if (v1.route().risk() < v2_in_force.route().risk()) {
    EXPECT_TRUE(PathEnters(v3.route(), ahead.x(), ahead.y(), radius));
  }
  ASSERT_TRUE(s->End().ok());
}

TEST_F(FlightTest, AZoneOverTheAircraftGivesAnAlertWithAReachableLandingSite) {
  auto s = Stream();
  ASSERT_TRUE(s->Write(Open()));
  std::optional<v1::FlightOutput> first = s->NextPlanOrAlert();
  ASSERT_TRUE(first.has_value() && first->has_plan());
  const v1::Pose start = first->plan().committed(0);
  ASSERT_TRUE(s->Write(Circle("police", start.x(), start.y(), 120.0)));
  std::optional<v1::FlightOutput> alert = s->NextPlanOrAlert();
  ASSERT_TRUE(alert.has_value());
  ASSERT_TRUE(alert->has_alert()) << alert->DebugString();
  const v1::FlightAlert& a = alert->alert();
  EXPECT_EQ(a.kind(), v1::FLIGHT_ALERT_INSIDE_ZONE);
  EXPECT_EQ(a.last_version(), 1u);
  ASSERT_TRUE(a.has_landing()) << a.detail();
  const v1::EmergencyLanding& l = a.landing();
  EXPECT_GE(l.altitude_margin_m(), 0.0);
  ASSERT_GE(l.glide_size(), 1);
  EXPECT_TRUE(SamePose(l.from(), a.commit_point()));
  // The glide descends all the way and ends on the site, above its terrain + clearance.
  for (int k = 1; k < l.glide_size(); ++k) EXPECT_LT(l.glide(k).z(), l.glide(k - 1).z());
  EXPECT_EQ(l.glide(l.glide_size() - 1).x(), l.site_pose().x());
  EXPECT_EQ(l.glide(l.glide_size() - 1).y(), l.site_pose().y());
  EXPECT_GE(l.glide(l.glide_size() - 1).z(), l.site_pose().z());
  // The session is alive: removing the zone gives a plan version again.
  ASSERT_TRUE(s->Write(Remove("police")));
  std::optional<v1::FlightOutput> back = s->NextPlanOrAlert();
  ASSERT_TRUE(back.has_value() && back->has_plan()) << back->DebugString();
  EXPECT_EQ(back->plan().version(), 2u);
  ASSERT_TRUE(s->End().ok());
}

TEST_F(FlightTest, AWindChangeReplansUnderTheNewWind) {
  auto s = Stream();
  ASSERT_TRUE(s->Write(Open()));
  std::optional<v1::FlightOutput> first = s->NextPlanOrAlert();
  ASSERT_TRUE(first.has_value() && first->has_plan());
  v1::FlightInput wind;
  wind.mutable_wind()->set_wind_speed_mps(6.0);
  wind.mutable_wind()->set_wind_from_deg(270.0);
  ASSERT_TRUE(s->Write(wind));
  std::optional<v1::FlightOutput> second = s->NextPlanOrAlert();
  ASSERT_TRUE(second.has_value() && second->has_plan()) << second->DebugString();
  const v1::FlightPlanVersion& v = second->plan();
  EXPECT_EQ(v.reason(), v1::FLIGHT_REASON_WIND);
  ExpectCommittedExtends(first->plan(), v);
  // The API's model parameters have no wind yet, so EvaluateRisk cannot be
  // asked for this one (tests/server/flight_session_test.cc checks it against
  // EvaluateTrajectory in the wind): the still-air answer differs.
  v1::EvaluateRiskRequest request;
  request.set_map("demo-city");
  *request.mutable_waypoints()->mutable_poses() = v.route().waypoints();
  v1::EvaluateRiskResponse calm;
  ASSERT_TRUE(client_->EvaluateRisk(request, &calm).ok());
  EXPECT_NE(calm.risk(), v.route().risk());
  // Flying east in a west wind is faster over the ground than in still air
  // (the route the plan settles on: the first version may be its first
  // solution, with detours).
  ASSERT_TRUE(s->End().ok());
  const v1::FlightPlanVersion settled = s->improved.empty() ? v : s->improved.back();
  EXPECT_LT(settled.route().flight_time_s(), settled.route().length_m() / kAirspeed);
}

TEST_F(FlightTest, BadInputsAreRefusedAndTheSessionLivesOn) {
  auto s = Stream();
  ASSERT_TRUE(s->Write(Open()));
  std::optional<v1::FlightOutput> first = s->NextPlanOrAlert();
  ASSERT_TRUE(first.has_value() && first->has_plan());
  ASSERT_TRUE(s->Write(Progress(5.0, 5.0 * kAirspeed)));
  const auto expect_refused = [&](const v1::FlightInput& in, const std::string& field,
                                  const std::string& words) {
    ASSERT_TRUE(s->Write(in));
    std::optional<v1::FlightRefusal> r = s->NextRefusal();
    ASSERT_TRUE(r.has_value()) << "no refusal for " << in.DebugString();
    EXPECT_EQ(r->field(), field) << r->message();
    EXPECT_NE(r->message().find(words), std::string::npos) << r->message();
  };
  // Time that runs backwards.
  expect_refused(Progress(4.0, 5.0 * kAirspeed), "position.time_s", "runs backwards");
  // A jump faster than the aircraft can fly.
  expect_refused(Progress(6.0, 5.0 * kAirspeed + 500.0), "position.progress_m",
                 "faster than the aircraft can fly");
  v1::FlightInput jump;
  jump.mutable_position()->set_time_s(6.0);
  *jump.mutable_position()->mutable_pose() = first->plan().committed(0);
  jump.mutable_position()->mutable_pose()->set_x(first->plan().committed(0).x() + 900.0);
  expect_refused(jump, "position.pose", "faster than the aircraft can fly");
  // A self-intersecting polygon (a bow tie).
  v1::FlightInput bow;
  bow.mutable_add_zone()->set_id("bow");
  for (auto [x, y] : std::vector<std::pair<double, double>>{{800, 800}, {1000, 1000}, {1000, 800}, {800, 1000}}) {
    v1::ZoneVertex* v = bow.mutable_add_zone()->mutable_polygon()->add_vertices();
    v->set_x(x);
    v->set_y(y);
  }
  expect_refused(bow, "add_zone", "intersects itself");
  expect_refused(Circle("big", 1000, 1000, 1e9), "add_zone", "radius_m");
  expect_refused(Remove("nothing"), "remove_zone.id", "not a zone");
  v1::FlightInput wind;
  wind.mutable_wind()->set_wind_speed_mps(100.0);
  expect_refused(wind, "wind", "wind_speed_mps");
  expect_refused(Open(), "open", "already open");
  // Alive: a zone far from the route still makes a version.
  ASSERT_TRUE(s->Write(Circle("far", 1900, 150, 50)));
  std::optional<v1::FlightOutput> v = s->NextPlanOrAlert();
  ASSERT_TRUE(v.has_value() && v->has_plan()) << (v ? v->DebugString() : "stream ended");
  EXPECT_EQ(v->plan().reason(), v1::FLIGHT_REASON_ZONE_ADDED);
  expect_refused(Circle("far", 100, 100, 50), "add_zone.id", "already");
  ASSERT_TRUE(s->End().ok());
}

TEST_F(FlightTest, ABadOpeningEndsTheStreamNamingTheField) {
  auto s = Stream();
  v1::FlightInput in = Open();
  in.mutable_open()->set_commit_horizon_s(-3);
  ASSERT_TRUE(s->Write(in));
  EXPECT_FALSE(s->Read().has_value());
  grpc::Status status = s->End();
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("open.commit_horizon_s"), std::string::npos)
      << status.error_message();
}

TEST(FlightResumeTest, AStreamBrokenMidFlightResumesOnAnotherServerWithTheSameMission) {
  auto a = ServerProcess::Start({});
  ASSERT_TRUE(a.ok()) << a.status();
  auto b = ServerProcess::Start({});
  ASSERT_TRUE(b.ok()) << b.status();
  v1::FlightPlanVersion last;
  double t = 0.0;
  {
    FlightStream s((*a)->Channel());
    ASSERT_TRUE(s.Write(Open()));
    std::optional<v1::FlightOutput> first = s.NextPlanOrAlert();
    ASSERT_TRUE(first.has_value() && first->has_plan());
    last = first->plan();
    // Fly until the commit point has moved once.
    while (last.version() < 2) {
      t += 1.0;
      ASSERT_TRUE(s.Write(Progress(t, kAirspeed * t)));
      if (kAirspeed * t + HorizonM() > last.committed_until_m()) {
        std::optional<v1::FlightOutput> o = s.NextPlanOrAlert();
        ASSERT_TRUE(o.has_value() && o->has_plan());
        last = o->plan();
      }
    }
    s.Cancel();  // the link breaks
  }
  // A new stream on the other server: the same mission, from what was committed.
  FlightStream s((*b)->Channel());
  v1::FlightInput in = Open();
  v1::FlightOpen* open = in.mutable_open();
  open->set_resume(true);
  open->set_time_s(t);
  *open->mutable_route() = last.committed();
  for (int k = 1; k < last.remainder().waypoints_size(); ++k) {
    *open->add_route() = last.remainder().waypoints(k);
  }
  open->set_committed_count(last.committed_size());
  open->set_progress_m(last.progress_m());
  ASSERT_TRUE(s.Write(in));
  std::optional<v1::FlightOutput> resumed = s.NextPlanOrAlert();
  ASSERT_TRUE(resumed.has_value() && resumed->has_plan()) << resumed->DebugString();
  const v1::FlightPlanVersion& v = resumed->plan();
  EXPECT_TRUE(v.resumed());
  ExpectCommittedExtends(last, v);
  EXPECT_EQ(v.progress_m(), last.progress_m());
  // Same goal.
  const v1::Pose& goal = v.remainder().waypoints(v.remainder().waypoints_size() - 1);
  const v1::Pose& old_goal = last.remainder().waypoints(last.remainder().waypoints_size() - 1);
  EXPECT_EQ(goal.x(), old_goal.x());
  EXPECT_EQ(goal.y(), old_goal.y());
  EXPECT_EQ(goal.z(), old_goal.z());
  client::RiskplanClient client((*b)->Channel());
  ExpectEvaluateRiskAgrees(client, v);
  // It flies on.
  ASSERT_TRUE(s.Write(Progress(t + 1.0, last.progress_m() + kAirspeed)));
  ASSERT_TRUE(s.End().ok());
}

TEST(FlightDrainTest, ADrainingServerEndsTheSessionUnavailableSoThatTheClientResumesElsewhere) {
  auto a = ServerProcess::Start({"--grace_period_ms=3000"});
  ASSERT_TRUE(a.ok()) << a.status();
  FlightStream s((*a)->Channel());
  ASSERT_TRUE(s.Write(Open()));
  std::optional<v1::FlightOutput> first = s.NextPlanOrAlert();
  ASSERT_TRUE(first.has_value() && first->has_plan());
  (*a)->Signal(SIGTERM);
  while (s.Read().has_value()) {
  }
  const grpc::Status status = s.End();
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE) << status.error_message();
  EXPECT_NE(status.error_message().find("resume"), std::string::npos) << status.error_message();
  EXPECT_EQ((*a)->Wait(absl::Seconds(30)), 0);
}

TEST(FlightCliTest, AScriptedFlightPrintsItsVersionsAndResumesOnTheOtherServerAfterABreak) {
  auto a = ServerProcess::Start({});
  ASSERT_TRUE(a.ok()) << a.status();
  auto b = ServerProcess::Start({});
  ASSERT_TRUE(b.ok()) << b.status();
  if ((*a)->connection().tls()) GTEST_SKIP() << "a list of addresses has no one TLS name";
  const std::string path = ::testing::TempDir() + "/fly-scenario.json";
  std::ofstream(path) << R"({
    "open": {"plan": {"map": "demo-city", "start": {"x": 300, "y": 375, "z": 240, "theta": 0.785},
                      "goal": {"x": 1700, "y": 1625, "z": 250, "theta": 0.785},
                      "budget": {"timeMs": 1000}, "seed": 7},
             "commitHorizonS": 10, "replanBudget": {"timeMs": 300}},
    "speedup": 40, "report_interval_s": 1, "max_time_s": 400,
    "events": [
      {"at_s": 15, "input": {"addZone": {"id": "far", "circle": {"x": 1800, "y": 250, "radiusM": 80}}}},
      {"at_s": 60, "break": true},
      {"at_s": 75, "input": {"removeZone": {"id": "far"}}},
      {"at_s": 80, "input": {"addZone": {"id": "bow", "polygon": {"vertices": [
        {"x": 800, "y": 800}, {"x": 1000, "y": 1000}, {"x": 1000, "y": 800}, {"x": 800, "y": 1000}]}}}}
    ]})";
  const CommandResult r = RunCommand(std::string(RISKPLAN_BIN_DIR) + "/riskplan fly --server=" +
                                     (*a)->address() + "," + (*b)->address() +
                                     " --scenario=" + path);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("[s1] version 1 OPENED"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("ZONE_ADDED"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("[s1] stream broke"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("[s2] version 1 OPENED"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("ZONE_REMOVED"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("intersects itself"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("2 stream(s): OK"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace riskplan::testing
