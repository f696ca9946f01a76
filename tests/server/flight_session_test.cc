// server/flight/ without gRPC: zones (checks, containment, closed cells),
// the emergency landing over the glide layer, and a session's versions in a
// wind: their risk is EvaluateTrajectory's bit for bit with the wind's model.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "core/flight/trajectory.h"
#include "gtest/gtest.h"
#include "server/api/proto_convert.h"
#include "server/flight/emergency_landing.h"
#include "server/flight/flight_session.h"
#include "server/flight/flight_zones.h"
#include "server/models/map_registry.h"
#include "server/models/model_cache.h"

namespace riskplan::server {
namespace {

v1::FlightZone Polygon(const std::string& id, std::vector<std::pair<double, double>> vertices) {
  v1::FlightZone z;
  z.set_id(id);
  for (auto [x, y] : vertices) {
    v1::ZoneVertex* v = z.mutable_polygon()->add_vertices();
    v->set_x(x);
    v->set_y(y);
  }
  return z;
}

TEST(FlightZonesTest, RefusesEveryBadZoneNamingWhatIsWrong) {
  const ZoneLimits limits;
  const auto error = [&](const v1::FlightZone& z) {
    absl::StatusOr<FlightZoneSpec> s = ZoneFromProto(z, limits, "add_zone");
    EXPECT_FALSE(s.ok());
    return s.ok() ? std::string() : std::string(s.status().message());
  };
  EXPECT_NE(error(Polygon("bow", {{0, 0}, {10, 10}, {10, 0}, {0, 10}})).find("edges 0 and 2 cross"),
            std::string::npos);
  EXPECT_NE(error(Polygon("fold", {{0, 0}, {10, 0}, {5, 0}})).find("fold back"), std::string::npos);
  EXPECT_NE(error(Polygon("two", {{0, 0}, {10, 0}})).find("3 to 64"), std::string::npos);
  EXPECT_NE(error(Polygon("", {{0, 0}, {10, 0}, {0, 10}})).find("add_zone.id"), std::string::npos);
  v1::FlightZone none;
  none.set_id("none");
  EXPECT_NE(error(none).find("no shape"), std::string::npos);
  v1::FlightZone half = Polygon("half", {{0, 0}, {10, 0}, {0, 10}});
  half.set_min_alt_m(100);
  EXPECT_NE(error(half).find("both min_alt_m and max_alt_m"), std::string::npos);
  v1::FlightZone interval = Polygon("late", {{0, 0}, {10, 0}, {0, 10}});
  interval.set_valid_from_s(50);
  interval.set_valid_until_s(40);
  EXPECT_NE(error(interval).find("valid_until_s"), std::string::npos);
  v1::FlightZone nan = Polygon("nan", {{0, 0}, {NAN, 0}, {0, 10}});
  EXPECT_NE(error(nan).find("vertices[1]"), std::string::npos);
}

TEST(FlightZonesTest, ContainsHonoursTheBandAndTheValidity) {
  v1::FlightZone z = Polygon("square", {{0, 0}, {100, 0}, {100, 100}, {0, 100}});
  z.set_min_alt_m(200);
  z.set_max_alt_m(300);
  z.set_valid_from_s(10);
  z.set_valid_until_s(20);
  absl::StatusOr<FlightZoneSpec> s = ZoneFromProto(z, {}, "zone");
  ASSERT_TRUE(s.ok()) << s.status();
  EXPECT_TRUE(s->Contains({50, 50, 250, 0}));
  EXPECT_FALSE(s->Contains({50, 50, 350, 0}));
  EXPECT_FALSE(s->Contains({150, 50, 250, 0}));
  EXPECT_TRUE(s->Contains({100, 50, 250, 0}));  // the boundary is in
  EXPECT_FALSE(s->ActiveAt(9.9));
  EXPECT_TRUE(s->ActiveAt(10));
  EXPECT_FALSE(s->ActiveAt(20));
}

TEST(FlightZonesTest, EveryPointOfAZoneLiesInAClosedCell) {
  absl::StatusOr<std::unique_ptr<MapRegistry>> registry = MapRegistry::DemoCity({.size_m = 2000});
  ASSERT_TRUE(registry.ok());
  std::shared_ptr<const RiskMap> map = (*registry)->Find("demo-city");
  v1::FlightZone circle;
  circle.set_id("c");
  circle.mutable_circle()->set_x(1003.3);
  circle.mutable_circle()->set_y(997.1);
  circle.mutable_circle()->set_radius_m(61.7);
  for (const v1::FlightZone& z :
       {circle, Polygon("p", {{700, 700}, {880.5, 731}, {760, 912.2}, {745, 780}})}) {
    FlightZoneSpec spec = *ZoneFromProto(z, {}, "zone");
    std::vector<uint8_t> nofly(map->layers().nofly.size(), 0);
    const int64_t closed = CloseZoneCells(*map, spec, &nofly);
    EXPECT_GT(closed, 0);
    for (double x = 600; x < 1100; x += 1.3) {
      for (double y = 600; y < 1100; y += 1.7) {
        int i = 0, j = 0;
        if (!spec.ContainsXY(x, y) || !map->CellOf(x, y, &i, &j)) continue;
        ASSERT_EQ(nofly[map->Index(i, j)], 1) << z.id() << " at " << x << ", " << y;
      }
    }
  }
}

class FlightSessionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    registry_ = *MapRegistry::DemoCity({.size_m = 2000});
    models_ = *RiskModelCache::Create(*registry_, 4);
    env_.maps = registry_.get();
    env_.models = models_.get();
  }
  v1::FlightInput Open() const {
    v1::FlightInput in;
    v1::PlanRequest* plan = in.mutable_open()->mutable_plan();
    plan->set_map("demo-city");
    plan->mutable_start()->set_x(300);
    plan->mutable_start()->set_y(375);
    plan->mutable_start()->set_z(240);
    plan->mutable_start()->set_theta(0.785);
    plan->mutable_goal()->set_x(1700);
    plan->mutable_goal()->set_y(1625);
    plan->mutable_goal()->set_z(250);
    plan->mutable_goal()->set_theta(0.785);
    plan->mutable_budget()->set_iterations(1500);
    plan->set_seed(3);
    in.mutable_open()->mutable_replan_budget()->set_iterations(800);
    return in;
  }
  std::unique_ptr<MapRegistry> registry_;
  std::unique_ptr<RiskModelCache> models_;
  FlightEnv env_;
  CancellationToken never_;
};

std::vector<Pose> Waypoints(const v1::Trajectory& t) {
  std::vector<Pose> poses;
  for (const v1::Pose& p : t.waypoints()) poses.push_back({p.x(), p.y(), p.z(), p.theta()});
  return poses;
}

TEST_F(FlightSessionTest, AVersionInAWindIsEvaluateTrajectoryOfItsRouteInThatWind) {
  FlightSession session(env_);
  absl::StatusOr<std::vector<v1::FlightOutput>> opened = session.Handle(Open(), never_);
  ASSERT_TRUE(opened.ok()) << opened.status();
  ASSERT_EQ(opened->size(), 1u);
  ASSERT_TRUE(opened->front().has_plan());
  v1::FlightInput wind;
  wind.mutable_wind()->set_wind_speed_mps(5.0);
  wind.mutable_wind()->set_wind_from_deg(200.0);
  absl::StatusOr<std::vector<v1::FlightOutput>> out = session.Handle(wind, never_);
  ASSERT_TRUE(out.ok());
  ASSERT_EQ(out->size(), 1u);
  ASSERT_TRUE(out->front().has_plan()) << out->front().DebugString();
  const v1::FlightPlanVersion& v = out->front().plan();
  EXPECT_EQ(v.reason(), v1::FLIGHT_REASON_WIND);
  ModelParams params;
  params.wind_speed_mps = 5.0;
  params.wind_from_deg = 200.0;
  std::shared_ptr<const RiskModel> model = *models_->Get(*registry_->Find("demo-city"), params);
  const std::vector<Pose> route = Waypoints(v.route());
  TrajectoryEvaluation e = *EvaluateTrajectory(*model, *PiecesFromWaypoints(route, params));
  EXPECT_TRUE(e.admissible);
  EXPECT_EQ(e.risk, v.route().risk());
  EXPECT_EQ(e.length_m, v.route().length_m());
  EXPECT_EQ(e.flight_time_s, v.route().flight_time_s());
}

TEST_F(FlightSessionTest, TheEmergencyLandingGlidesDownTheLayerToASite) {
  std::shared_ptr<const RiskModel> model = models_->Default(*registry_->Find("demo-city"));
  std::shared_ptr<const std::vector<double>> glide = *GlideLayerOf(*model, StopCondition());
  const RiskMap& map = model->map();
  const Pose from{1000, 1000, 260, 0.0};
  int i = 0, j = 0;
  ASSERT_TRUE(map.CellOf(from.x, from.y, &i, &j));
  ASSERT_LE((*glide)[map.Index(i, j)], from.z);
  std::optional<EmergencyOption> option = FindEmergencyLanding(map, model->params(), *glide, from);
  ASSERT_TRUE(option.has_value());
  EXPECT_EQ(option->altitude_margin_m, from.z - (*glide)[map.Index(i, j)]);
  bool is_site = false;
  for (const LandingSite& s : map.landing_sites()) {
    is_site = is_site || (s.i == option->site_i && s.j == option->site_j);
  }
  EXPECT_TRUE(is_site);
  for (const Pose& p : option->glide) {
    ASSERT_TRUE(map.CellOf(p.x, p.y, &i, &j));
    EXPECT_GE(p.z + 1e-9, (*glide)[map.Index(i, j)]);
  }
  // Below the glide altitude of its cell: no site is reachable.
  ASSERT_TRUE(map.CellOf(from.x, from.y, &i, &j));
  const Pose low{from.x, from.y, (*glide)[map.Index(i, j)] - 1.0, 0.0};
  EXPECT_FALSE(FindEmergencyLanding(map, model->params(), *glide, low).has_value());
}

TEST_F(FlightSessionTest, AZoneThatBeginsLaterActsWhenTheClockReachesIt) {
  FlightSession session(env_);
  absl::StatusOr<std::vector<v1::FlightOutput>> opened = session.Handle(Open(), never_);
  ASSERT_TRUE(opened.ok() && opened->size() == 1u && opened->front().has_plan());
  const v1::Trajectory& route = opened->front().plan().route();
  const double step = route.length_m() / (route.path_size() - 1);
  const v1::Pose& ahead = route.path(static_cast<int>(std::lround(900.0 / step)));
  v1::FlightInput zone;
  zone.mutable_add_zone()->set_id("later");
  zone.mutable_add_zone()->mutable_circle()->set_x(ahead.x());
  zone.mutable_add_zone()->mutable_circle()->set_y(ahead.y());
  zone.mutable_add_zone()->mutable_circle()->set_radius_m(120);
  zone.mutable_add_zone()->set_valid_from_s(5);
  absl::StatusOr<std::vector<v1::FlightOutput>> none = session.Handle(zone, never_);
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());  // not active yet: nothing changes
  v1::FlightInput report;
  report.mutable_position()->set_time_s(6);
  report.mutable_position()->set_progress_m(6 * 18.0);
  absl::StatusOr<std::vector<v1::FlightOutput>> out = session.Handle(report, never_);
  ASSERT_TRUE(out.ok());
  ASSERT_EQ(out->size(), 1u);
  ASSERT_TRUE(out->front().has_plan()) << out->front().DebugString();
  const v1::FlightPlanVersion& v = out->front().plan();
  EXPECT_EQ(v.reason(), v1::FLIGHT_REASON_ZONE_TIMED);
  ASSERT_EQ(v.active_zones_size(), 1);
  for (const v1::Pose& p : v.route().path()) {
    EXPECT_GT(std::hypot(p.x() - ahead.x(), p.y() - ahead.y()), 120.0);
  }
}

TEST_F(FlightSessionTest, APoseOffTheRouteIsPlannedFrom) {
  FlightSession session(env_);
  ASSERT_TRUE(session.Handle(Open(), never_).ok());
  v1::FlightInput report;
  report.mutable_position()->set_time_s(10);
  v1::Pose* pose = report.mutable_position()->mutable_pose();
  pose->set_x(300 - 100 * std::sin(0.785));
  pose->set_y(375 + 100 * std::cos(0.785));
  pose->set_z(240);
  pose->set_theta(0.785);
  absl::StatusOr<std::vector<v1::FlightOutput>> out = session.Handle(report, never_);
  ASSERT_TRUE(out.ok());
  ASSERT_EQ(out->size(), 1u);
  ASSERT_TRUE(out->front().has_plan()) << out->front().DebugString();
  const v1::FlightPlanVersion& v = out->front().plan();
  EXPECT_EQ(v.reason(), v1::FLIGHT_REASON_OFF_ROUTE);
  EXPECT_EQ(v.committed(0).x(), pose->x());
  EXPECT_EQ(v.committed(0).y(), pose->y());
  EXPECT_EQ(v.progress_m(), 0.0);
  EXPECT_GE(v.committed_until_m(), (10.0 + 1.0) * 18.0);
}

TEST_F(FlightSessionTest, TheFirstMessageMustOpenAndAnInputAfterTheEndIsRefused) {
  FlightSession session(env_);
  v1::FlightInput report;
  report.mutable_position()->set_time_s(1);
  EXPECT_FALSE(session.Handle(report, never_).ok());
  FlightSession s2(env_);
  ASSERT_TRUE(s2.Handle(Open(), never_).ok());
  v1::FlightInput end;
  end.mutable_end();
  ASSERT_TRUE(s2.Handle(end, never_).ok());
  EXPECT_TRUE(s2.ended());
  absl::StatusOr<std::vector<v1::FlightOutput>> after = s2.Handle(report, never_);
  ASSERT_TRUE(after.ok());
  ASSERT_EQ(after->size(), 1u);
  EXPECT_TRUE(after->front().has_refusal());
}

// The PlanRequest's flight limits apply to the whole mission (issue 35):
// every version carries the committed prefix's numbers and the mission's
// margins, and a remainder must fit what the committed prefix leaves.
const v1::FlightMargin* FindMargin(const v1::FlightPlanVersion& v, const std::string& name) {
  for (const v1::FlightMargin& m : v.margins()) {
    if (m.limit() == name) return &m;
  }
  return nullptr;
}

TEST_F(FlightSessionTest, TheFlightLimitsApplyToTheWholeMission) {
  // A first session with a generous endurance: the mission's margin.
  v1::FlightInput open = Open();
  open.mutable_open()->mutable_plan()->mutable_limits()->set_max_flight_time_s(1000.0);
  FlightSession session(env_);
  absl::StatusOr<std::vector<v1::FlightOutput>> opened = session.Handle(open, never_);
  ASSERT_TRUE(opened.ok()) << opened.status();
  ASSERT_EQ(opened->size(), 1u);
  ASSERT_TRUE(opened->front().has_plan()) << opened->front().DebugString();
  const v1::FlightPlanVersion& first = opened->front().plan();
  {
    // The commit point moved ahead of the start by the horizon.
    std::vector<Pose> poses;
    for (const v1::Pose& p : first.committed()) poses.push_back({p.x(), p.y(), p.z(), p.theta()});
    ASSERT_GE(poses.size(), 2u);
    ModelParams params;
    std::shared_ptr<const RiskModel> model = *models_->Get(*registry_->Find("demo-city"), params);
    const TrajectoryEvaluation e = *EvaluateTrajectory(*model, *PiecesFromWaypoints(poses, params));
    EXPECT_EQ(first.committed_flight_time_s(), e.flight_time_s);
    EXPECT_EQ(first.committed_length_m(), e.length_m);
    EXPECT_EQ(first.committed_risk(), e.risk);
  }
  const v1::FlightMargin* margin = FindMargin(first, "max_flight_time_s");
  ASSERT_NE(margin, nullptr);
  EXPECT_EQ(margin->bound(), 1000.0);
  EXPECT_EQ(margin->value(), first.route().flight_time_s());
  EXPECT_EQ(margin->margin(), 1000.0 - first.route().flight_time_s());
  EXPECT_LE(first.route().flight_time_s(), 1000.0);
  EXPECT_EQ(FindMargin(first, "max_length_m"), nullptr);  // not set

  // The route resumed with most of it committed: the committed prefix's
  // numbers, exact.
  const std::vector<Pose> route = Waypoints(first.route());
  ASSERT_GE(route.size(), 4u);
  const size_t committed = route.size() - 1;
  ModelParams params;
  std::shared_ptr<const RiskModel> model = *models_->Get(*registry_->Find("demo-city"), params);
  const TrajectoryEvaluation prefix = *EvaluateTrajectory(
      *model, *PiecesFromWaypoints(std::vector<Pose>(route.begin(), route.begin() + committed),
                                   params));
  ASSERT_GT(prefix.flight_time_s, 0.0);
  const auto resumed = [&](double endurance) {
    v1::FlightInput in = Open();
    in.mutable_open()->mutable_plan()->mutable_limits()->set_max_flight_time_s(endurance);
    in.mutable_open()->set_resume(true);
    for (const Pose& p : route) PoseToProto(p, in.mutable_open()->add_route());
    in.mutable_open()->set_committed_count(static_cast<uint32_t>(committed));
    FlightSession s(env_);
    absl::StatusOr<std::vector<v1::FlightOutput>> out = s.Handle(in, never_);
    EXPECT_TRUE(out.ok()) << out.status();
    EXPECT_EQ(out->size(), 1u);
    return out->front();
  };
  {
    const v1::FlightOutput out = resumed(first.route().flight_time_s() + 1.0);
    ASSERT_TRUE(out.has_plan()) << out.DebugString();
    const v1::FlightPlanVersion& v = out.plan();
    EXPECT_EQ(v.committed_flight_time_s(), prefix.flight_time_s);
    EXPECT_EQ(v.committed_length_m(), prefix.length_m);
    EXPECT_EQ(v.committed_risk(), prefix.risk);
    // The remainder fits what the prefix leaves, so the mission fits.
    EXPECT_LE(v.remainder().flight_time_s(),
              first.route().flight_time_s() + 1.0 - prefix.flight_time_s);
    const v1::FlightMargin* m = FindMargin(v, "max_flight_time_s");
    ASSERT_NE(m, nullptr);
    EXPECT_GE(m->margin(), 0.0);
  }
  {
    // The committed prefix alone breaks the endurance: nothing can fit.
    const v1::FlightOutput out = resumed(prefix.flight_time_s - 1.0);
    ASSERT_TRUE(out.has_alert()) << out.DebugString();
    EXPECT_EQ(out.alert().kind(), v1::FLIGHT_ALERT_NO_REMAINDER);
    EXPECT_NE(out.alert().detail().find("already uses"), std::string::npos)
        << out.alert().detail();
    EXPECT_NE(out.alert().detail().find("max_flight_time_s"), std::string::npos)
        << out.alert().detail();
  }
  {
    // What is left is less than half the straight line from the commit
    // point: the planner's note says so.
    const Pose& c = route[committed - 1];
    const Pose goal{1700, 1625, 250, 0.785};
    const double straight =
        std::hypot(goal.x - c.x, goal.y - c.y) / params.airspeed_mps;
    const v1::FlightOutput out = resumed(prefix.flight_time_s + 0.5 * straight);
    ASSERT_TRUE(out.has_alert()) << out.DebugString();
    EXPECT_EQ(out.alert().kind(), v1::FLIGHT_ALERT_NO_REMAINDER);
    EXPECT_NE(out.alert().detail().find("no trajectory within the endurance"), std::string::npos)
        << out.alert().detail();
  }
}

v1::FlightInput CircleZone(const std::string& id, double x, double y, double r) {
  v1::FlightInput in;
  in.mutable_add_zone()->set_id(id);
  in.mutable_add_zone()->mutable_circle()->set_x(x);
  in.mutable_add_zone()->mutable_circle()->set_y(y);
  in.mutable_add_zone()->mutable_circle()->set_radius_m(r);
  return in;
}

v1::FlightInput RemoveZone(const std::string& id) {
  v1::FlightInput in;
  in.mutable_remove_zone()->set_id(id);
  return in;
}

// The model of the moment, derived from the model before it without a map
// copy: after zones come and go (in still air and after a wind), it shares
// the session map's layers, its no-fly layer is the map's with the active
// zones closed, and its glide layer is the full computation's in every cell.
TEST_F(FlightSessionTest, TheModelOfTheMomentIsTheFullModelOfTheZonesBitForBit) {
  for (const bool windy : {false, true}) {
    SCOPED_TRACE(windy ? "wind" : "still air");
    FlightSession session(env_);
    ASSERT_TRUE(session.Handle(Open(), never_).ok());
    if (windy) {
      v1::FlightInput wind;
      wind.mutable_wind()->set_wind_speed_mps(5.0);
      wind.mutable_wind()->set_wind_from_deg(200.0);
      ASSERT_TRUE(session.Handle(wind, never_).ok());
    }
    std::shared_ptr<const RiskMap> map = registry_->Find("demo-city");
    struct Zone {
      std::string id;
      double x, y, r;
    };
    const std::vector<Zone> zones = {
        {"a", 900, 900, 120}, {"b", 1200, 700, 200}, {"c", 1000, 800, 150}};
    // Active zone ids after each input: add a, b, c, remove a, remove c, remove b.
    const std::vector<std::pair<std::string, bool>> inputs = {
        {"a", true}, {"b", true}, {"c", true}, {"a", false}, {"c", false}, {"b", false}};
    std::vector<std::string> active;
    for (const auto& input : inputs) {
      // Named copies: a lambda may not capture a structured binding in C++17 (clang 14).
      const std::string& id = input.first;
      const bool add = input.second;
      SCOPED_TRACE(id + (add ? " added" : " removed"));
      const Zone& z = *std::find_if(zones.begin(), zones.end(), [&](const Zone& z) { return z.id == id; });
      ASSERT_TRUE(session.Handle(add ? CircleZone(z.id, z.x, z.y, z.r) : RemoveZone(z.id), never_).ok());
      if (add) {
        active.push_back(id);
      } else {
        active.erase(std::find(active.begin(), active.end(), id));
      }
      std::vector<uint8_t> nofly = map->layers().nofly;
      for (const std::string& a : active) {
        const Zone& az = *std::find_if(zones.begin(), zones.end(), [&](const Zone& q) { return q.id == a; });
        v1::FlightInput in = CircleZone(az.id, az.x, az.y, az.r);
        CloseZoneCells(*map, *ZoneFromProto(in.add_zone(), {}, "zone"), &nofly);
      }
      const RiskModel& model = *session.model();
      EXPECT_TRUE(model.map().SharesLayersWith(*map));
      ASSERT_EQ(model.map().nofly_layer(), nofly);
      std::shared_ptr<const std::vector<double>> full =
          *GlideLayerWith(*map, nofly, model.params(), StopCondition());
      const std::vector<double>& got = *model.glide_layer();
      ASSERT_EQ(got.size(), full->size());
      for (size_t k = 0; k < got.size(); ++k) {
        ASSERT_EQ(std::memcmp(&got[k], &(*full)[k], sizeof(double)), 0) << "cell " << k;
      }
    }
    // No zone left: the cache's model itself.
    ModelParams params;
    if (windy) {
      params.wind_speed_mps = 5.0;
      params.wind_from_deg = 200.0;
    }
    EXPECT_EQ(session.model(), *models_->Get(*map, params));
  }
}

// With an early sink a zone's first admissible remainder goes out before the
// plan ends; a later IMPROVED version keeps the commit point and lowers the
// risk; every version is admissible with the zone closed.
TEST_F(FlightSessionTest, WithAnEarlySinkTheFirstAdmissibleRemainderGoesOutAtOnce) {
  FlightSession session(env_);
  std::vector<v1::FlightOutput> early;
  session.set_early_sink([&](v1::FlightOutput o) { early.push_back(std::move(o)); });
  absl::StatusOr<std::vector<v1::FlightOutput>> opened = session.Handle(Open(), never_);
  ASSERT_TRUE(opened.ok() && opened->size() == 1u && opened->front().has_plan());
  EXPECT_TRUE(early.empty());  // the opening is not a change: one version after the plan
  const v1::Trajectory& route = opened->front().plan().route();
  const double step = route.length_m() / (route.path_size() - 1);
  const v1::Pose& ahead = route.path(static_cast<int>(std::lround(700.0 / step)));
  absl::StatusOr<std::vector<v1::FlightOutput>> out =
      session.Handle(CircleZone("fire", ahead.x(), ahead.y(), 120), never_);
  ASSERT_TRUE(out.ok());
  ASSERT_EQ(early.size(), 1u);
  ASSERT_TRUE(early.front().has_plan()) << early.front().DebugString();
  const v1::FlightPlanVersion& first = early.front().plan();
  EXPECT_EQ(first.reason(), v1::FLIGHT_REASON_ZONE_ADDED);
  std::vector<const v1::FlightPlanVersion*> versions = {&first};
  ASSERT_LE(out->size(), 1u);
  if (!out->empty()) {
    ASSERT_TRUE(out->front().has_plan());
    const v1::FlightPlanVersion& better = out->front().plan();
    EXPECT_EQ(better.reason(), v1::FLIGHT_REASON_IMPROVED);
    EXPECT_EQ(better.version(), first.version() + 1);
    EXPECT_EQ(better.committed_until_m(), first.committed_until_m());
    EXPECT_LT(better.remainder().risk(), first.remainder().risk());
    versions.push_back(&better);
  }
  for (const v1::FlightPlanVersion* v : versions) {
    for (const v1::Pose& p : v->route().path()) {
      EXPECT_GT(std::hypot(p.x() - ahead.x(), p.y() - ahead.y()), 120.0);
    }
    const std::vector<Pose> poses = Waypoints(v->route());
    TrajectoryEvaluation e =
        *EvaluateTrajectory(*session.model(), *PiecesFromWaypoints(poses, ModelParams{}));
    EXPECT_TRUE(e.admissible);
    EXPECT_EQ(e.risk, v->route().risk());
  }
}

}  // namespace
}  // namespace riskplan::server
