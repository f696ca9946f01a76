// WGS84 at the API's edge: requests in either frame become the same local
// values, a WGS84 field on a map without geo-reference is refused naming the
// map and the field, answers carry both frames, and GetRiskLayer is counted
// and refused before anything is computed.
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "core/flight/trajectory.h"
#include "geo/geo_frame.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "server/api/proto_convert.h"
#include "server/api/request_validation.h"
#include "server/api/risk_layer_request.h"
#include "tests/core/test_maps.h"

namespace riskplan::server {
namespace {

using ::testing::HasSubstr;

constexpr double kDeg = kPi / 180.0;
constexpr double kLat0 = 49.6;
constexpr double kLon0 = 6.1;

// 2 km x 2 km, flat at 100 m AMSL, its south-west corner (1000, -500) at
// (49.6, 6.1); one landing site.
std::shared_ptr<const RiskMap> GeoCity() {
  MapHeader header;
  header.name = "geo-city";
  header.x0 = 1000.0;
  header.y0 = -500.0;
  header.res = 10.0;
  header.nx = 200;
  header.ny = 200;
  header.geo = GeoReference{kLat0, kLon0, "test"};
  MapLayers layers;
  const size_t n = 200 * 200;
  layers.density.assign(n, 0.001f);
  layers.shelter.assign(n, 2.0f);
  layers.terrain.assign(n, 100.0f);
  layers.nofly.assign(n, 0);
  layers.landing_sites = {{"field", 20, 30}};
  auto map = RiskMap::Create(std::move(header), std::move(layers));
  EXPECT_TRUE(map.ok()) << map.status();
  return *map;
}

class Wgs84ApiTest : public ::testing::Test {
 protected:
  Wgs84ApiTest() {
    auto registry = MapRegistry::FromMaps(
        {GeoCity(), testing_maps::UniformMap(200, 200, 10.0, 0.001f, 2.0f, 100.0f, {}, "flat")});
    EXPECT_TRUE(registry.ok()) << registry.status();
    registry_ = *std::move(registry);
    frame_ = registry_->Frame("geo-city");
  }

  geo::GeoPose Geo(double x, double y, double z, double theta) const {
    auto geo = frame_->ToWgs84(std::vector<Pose>{{x, y, z, theta}});
    EXPECT_TRUE(geo.ok()) << geo.status();
    return (*geo)[0];
  }

  static void Set(const geo::GeoPose& g, v1::GeoPose* out) {
    out->set_lat_deg(g.lat_deg);
    out->set_lon_deg(g.lon_deg);
    out->set_alt_m(g.alt_m);
    out->set_heading_deg(g.heading_deg);
  }

  v1::PlanRequest GeoPlan() const {
    v1::PlanRequest r;
    r.set_map("geo-city");
    Set(Geo(1200, -300, 180, 0.3), r.mutable_start_wgs84());
    Set(Geo(2800, 1300, 190, 2.0), r.mutable_goal_wgs84());
    r.mutable_budget()->set_time_ms(500);
    return r;
  }

  std::unique_ptr<MapRegistry> registry_;
  std::shared_ptr<const geo::GeoFrame> frame_;
  RequestLimits limits_;
};

TEST_F(Wgs84ApiTest, OnlyGeoReferencedMapsHaveAFrame) {
  ASSERT_NE(frame_, nullptr);
  EXPECT_EQ(registry_->Frame("flat"), nullptr);
  EXPECT_EQ(registry_->Frame("nowhere"), nullptr);
  EXPECT_DOUBLE_EQ(frame_->origin_lat_deg(), kLat0);
  EXPECT_DOUBLE_EQ(frame_->x0(), 1000.0);
}

TEST_F(Wgs84ApiTest, AMapWhoseGeoReferenceIsNoPlaceOnEarthIsRefused) {
  MapHeader header = GeoCity()->header();
  header.geo->origin_lat_deg = 95.0;
  auto map = RiskMap::Create(header, GeoCity()->layers());
  ASSERT_TRUE(map.ok());
  auto registry = MapRegistry::FromMaps({*map});
  ASSERT_FALSE(registry.ok());
  EXPECT_THAT(registry.status().message(), HasSubstr("map 'geo-city': geo-reference"));
}

TEST_F(Wgs84ApiTest, PlanEndpointsInWgs84BecomeTheLocalPoses) {
  absl::StatusOr<PlanSpec> spec = ValidatePlanRequest(GeoPlan(), *registry_, limits_);
  ASSERT_TRUE(spec.ok()) << spec.status();
  EXPECT_EQ(spec->frame, frame_);
  EXPECT_NEAR(spec->start.x, 1200.0, 1e-6);
  EXPECT_NEAR(spec->start.y, -300.0, 1e-6);
  EXPECT_EQ(spec->start.z, 180.0);
  EXPECT_NEAR(spec->start.theta, 0.3, 1e-9);
  EXPECT_NEAR(spec->goal.x, 2800.0, 1e-6);
  EXPECT_NEAR(spec->goal.y, 1300.0, 1e-6);
  EXPECT_NEAR(spec->goal.theta, 2.0, 1e-9);

  // Frames may be mixed: a local start with a WGS84 goal.
  v1::PlanRequest r = GeoPlan();
  r.mutable_start()->set_x(1200);
  r.mutable_start()->set_y(-300);
  r.mutable_start()->set_z(180);
  spec = ValidatePlanRequest(r, *registry_, limits_);
  ASSERT_TRUE(spec.ok()) << spec.status();
  EXPECT_EQ(spec->start.x, 1200.0);
  EXPECT_NEAR(spec->goal.x, 2800.0, 1e-6);

  // A heading due north at a point east of the origin's meridian leans
  // west of the local y axis by the grid convergence: theta = pi/2 + gamma.
  r = GeoPlan();
  geo::GeoPose north = Geo(2900, 1400, 180, 0.0);
  north.heading_deg = 0.0;
  Set(north, r.mutable_start_wgs84());
  spec = ValidatePlanRequest(r, *registry_, limits_);
  ASSERT_TRUE(spec.ok()) << spec.status();
  auto gamma = frame_->GridConvergenceRad({2900, 1400});
  ASSERT_TRUE(gamma.ok());
  EXPECT_GT(*gamma, 0.0);
  EXPECT_NEAR(spec->start.theta, kPi / 2 + *gamma, 1e-6);
  EXPECT_NEAR(*gamma, (north.lon_deg - kLon0) * kDeg * std::sin(kLat0 * kDeg), 1e-6);
}

TEST_F(Wgs84ApiTest, Wgs84OnAMapWithoutGeoReferenceNamesTheMapAndTheField) {
  v1::PlanRequest r = GeoPlan();
  r.set_map("flat");
  absl::StatusOr<PlanSpec> spec = ValidatePlanRequest(r, *registry_, limits_);
  ASSERT_EQ(spec.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(spec.status().message(),
              HasSubstr("start_wgs84: map 'flat' has no geo-reference, so it takes positions in "
                        "its local metres only (start)"));

  v1::EvaluateRiskRequest e;
  e.set_map("flat");
  for (int k = 0; k < 2; ++k) {
    v1::GeoPoint3* p = e.mutable_polyline_wgs84()->add_points();
    p->set_lat_deg(kLat0);
    p->set_lon_deg(kLon0);
  }
  absl::StatusOr<EvaluateSpec> eval = ValidateEvaluateRequest(e, *registry_, limits_);
  ASSERT_EQ(eval.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(eval.status().message(),
              HasSubstr("polyline_wgs84: map 'flat' has no geo-reference"));

  // Local endpoints on the plain map, but an obstacle in WGS84.
  r = GeoPlan();
  r.set_map("flat");
  r.set_algorithm(v1::RRT);
  r.mutable_start()->set_x(200);
  r.mutable_start()->set_y(200);
  r.mutable_start()->set_z(180);
  r.mutable_goal()->set_x(500);
  r.mutable_goal()->set_y(500);
  r.mutable_goal()->set_z(180);
  r.add_obstacle_points_wgs84()->set_lat_deg(kLat0);
  spec = ValidatePlanRequest(r, *registry_, limits_);
  ASSERT_EQ(spec.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(spec.status().message(), HasSubstr("obstacle_points_wgs84: map 'flat'"));
}

TEST_F(Wgs84ApiTest, BadWgs84NumbersAreNamed) {
  v1::PlanRequest r = GeoPlan();
  r.mutable_start_wgs84()->set_lat_deg(95.0);
  absl::StatusOr<PlanSpec> spec = ValidatePlanRequest(r, *registry_, limits_);
  EXPECT_THAT(spec.status().message(),
              HasSubstr("start_wgs84.lat_deg has value 95; it must be in [-90, 90]"));
  r = GeoPlan();
  r.mutable_goal_wgs84()->set_heading_deg(std::nan(""));
  spec = ValidatePlanRequest(r, *registry_, limits_);
  EXPECT_THAT(spec.status().message(), HasSubstr("goal_wgs84.heading_deg has value nan"));
  r = GeoPlan();
  r.mutable_goal_wgs84()->set_lon_deg(-200.0);
  spec = ValidatePlanRequest(r, *registry_, limits_);
  EXPECT_THAT(spec.status().message(), HasSubstr("goal_wgs84.lon_deg has value -200"));
  // Inside the globe but outside the map: both frames in the message.
  r = GeoPlan();
  r.mutable_start_wgs84()->set_lat_deg(49.5);
  spec = ValidatePlanRequest(r, *registry_, limits_);
  ASSERT_EQ(spec.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(spec.status().message(), HasSubstr("start_wgs84 (lat, lon) = (49.5, "));
  EXPECT_THAT(spec.status().message(), HasSubstr("is outside map 'geo-city'"));
  EXPECT_THAT(spec.status().message(), HasSubstr("latitudes 49.59"));
  // Farther than the frame reaches.
  r = GeoPlan();
  r.mutable_start_wgs84()->set_lat_deg(-49.6);
  spec = ValidatePlanRequest(r, *registry_, limits_);
  EXPECT_THAT(spec.status().message(), HasSubstr("start_wgs84: (-49.6"));
  EXPECT_THAT(spec.status().message(), HasSubstr("1000 km"));
  // Neither frame given.
  r = GeoPlan();
  r.clear_start_wgs84();
  spec = ValidatePlanRequest(r, *registry_, limits_);
  EXPECT_THAT(spec.status().message(), HasSubstr("start is required (or start_wgs84"));
}

TEST_F(Wgs84ApiTest, ObstaclesInBothFramesShareOneLimit) {
  v1::PlanRequest r = GeoPlan();
  r.set_algorithm(v1::RRT);
  const geo::GeoPose p = Geo(1500, 500, 0, 0);
  v1::GeoPoint2* o = r.add_obstacle_points_wgs84();
  o->set_lat_deg(p.lat_deg);
  o->set_lon_deg(p.lon_deg);
  r.add_obstacle_points()->set_x(1700);
  absl::StatusOr<PlanSpec> spec = ValidatePlanRequest(r, *registry_, limits_);
  ASSERT_TRUE(spec.ok()) << spec.status();
  ASSERT_EQ(spec->options.obstacle_points.size(), 2u);
  EXPECT_NEAR(spec->options.obstacle_points[1].x, 1500.0, 1e-6);
  EXPECT_NEAR(spec->options.obstacle_points[1].y, 500.0, 1e-6);
  limits_.max_obstacle_points = 1;
  spec = ValidatePlanRequest(r, *registry_, limits_);
  EXPECT_THAT(
      spec.status().message(),
      HasSubstr("obstacle_points has 1 points and obstacle_points_wgs84 1; the limit is 1"));
  limits_.max_obstacle_points = 10;
  r.mutable_obstacle_points_wgs84(0)->set_lat_deg(-91);
  spec = ValidatePlanRequest(r, *registry_, limits_);
  EXPECT_THAT(spec.status().message(), HasSubstr("obstacle_points_wgs84[0].lat_deg has value -91"));
}

TEST_F(Wgs84ApiTest, EvaluateTrajectoriesInWgs84) {
  v1::EvaluateRiskRequest e;
  e.set_map("geo-city");
  const std::vector<Pose> local = {
      {1100, -400, 200, 0.2}, {2000, 500, 210, 1.0}, {2900, 1400, 220, 2.5}};
  for (const Pose& p : local)
    Set(Geo(p.x, p.y, p.z, p.theta), e.mutable_waypoints_wgs84()->add_poses());
  absl::StatusOr<EvaluateSpec> spec = ValidateEvaluateRequest(e, *registry_, limits_);
  ASSERT_TRUE(spec.ok()) << spec.status();
  ASSERT_EQ(spec->waypoints.size(), 3u);
  for (size_t k = 0; k < 3; ++k) {
    EXPECT_NEAR(spec->waypoints[k].x, local[k].x, 1e-6);
    EXPECT_NEAR(spec->waypoints[k].y, local[k].y, 1e-6);
    EXPECT_EQ(spec->waypoints[k].z, local[k].z);
    EXPECT_NEAR(spec->waypoints[k].theta, local[k].theta, 1e-9);
  }
  EXPECT_EQ(spec->frame, frame_);

  e.clear_waypoints_wgs84();
  for (const Pose& p : local) {
    const geo::GeoPose g = Geo(p.x, p.y, p.z, p.theta);
    v1::GeoPoint3* q = e.mutable_polyline_wgs84()->add_points();
    q->set_lat_deg(g.lat_deg);
    q->set_lon_deg(g.lon_deg);
    q->set_alt_m(g.alt_m);
  }
  spec = ValidateEvaluateRequest(e, *registry_, limits_);
  ASSERT_TRUE(spec.ok()) << spec.status();
  ASSERT_EQ(spec->polyline.size(), 3u);
  EXPECT_NEAR(spec->polyline[2].x, 2900.0, 1e-6);
  EXPECT_EQ(spec->polyline[2].z, 220.0);

  e.mutable_polyline_wgs84()->mutable_points(1)->set_alt_m(std::numeric_limits<double>::infinity());
  spec = ValidateEvaluateRequest(e, *registry_, limits_);
  EXPECT_THAT(spec.status().message(), HasSubstr("polyline_wgs84.points[1].alt_m has value inf"));
  limits_.max_waypoints = 2;
  spec = ValidateEvaluateRequest(e, *registry_, limits_);
  EXPECT_THAT(spec.status().message(),
              HasSubstr("polyline_wgs84.points has 3 points; it must have 2 to 2"));
}

TEST_F(Wgs84ApiTest, PathSpacingIsBoundedAndItsPosesCounted) {
  v1::EvaluateRiskRequest e;
  e.set_map("flat");
  for (double x : {100.0, 1900.0}) {
    v1::Point3* p = e.mutable_polyline()->add_points();
    p->set_x(x);
    p->set_y(500);
    p->set_z(180);
  }
  for (double bad : {-1.0, 0.5, 200000.0, std::nan("")}) {
    e.set_path_spacing_m(bad);
    absl::StatusOr<EvaluateSpec> spec = ValidateEvaluateRequest(e, *registry_, limits_);
    ASSERT_FALSE(spec.ok()) << bad;
    EXPECT_THAT(spec.status().message(), HasSubstr("path_spacing_m has value"));
  }
  e.set_path_spacing_m(50.0);
  absl::StatusOr<EvaluateSpec> spec = ValidateEvaluateRequest(e, *registry_, limits_);
  ASSERT_TRUE(spec.ok()) << spec.status();
  EXPECT_EQ(spec->path_spacing_m, 50.0);
  // 1800 m every 50 m: 37 poses.
  EXPECT_EQ(PathPoseCount(1800.0, 50.0), 37);
  EXPECT_TRUE(CheckPathCount(1800.0, 50.0, limits_).ok());
  limits_.max_response_samples = 36;
  const absl::Status s = CheckPathCount(1800.0, 50.0, limits_);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("has 37 poses; at most 36 can be returned"));
  EXPECT_FALSE(CheckPathCount(1e300, 1.0, limits_).ok());  // saturates, never wraps
}

TEST_F(Wgs84ApiTest, RiskLayerRequestsAreCountedAndRefusedBeforeAnyWork) {
  v1::GetRiskLayerRequest r;
  r.set_map("geo-city");
  absl::StatusOr<RiskLayerSpec> spec = ValidateRiskLayerRequest(r, *registry_, limits_);
  ASSERT_TRUE(spec.ok()) << spec.status();
  EXPECT_EQ(spec->cells, 200 * 200);
  EXPECT_EQ(spec->evaluations, 200 * 200);
  EXPECT_EQ(spec->options.stride, 1);            // 0 means 1
  EXPECT_EQ(spec->options.height_agl_m, 100.0);  // 0 means 100
  EXPECT_EQ(spec->options.threads, 1);

  // A local region: the cells it overlaps, clipped to the map.
  r.mutable_region()->set_x_min_m(1015);
  r.mutable_region()->set_x_max_m(1101);
  r.mutable_region()->set_y_min_m(-1000);
  r.mutable_region()->set_y_max_m(-480);
  r.set_stride(2);
  spec = ValidateRiskLayerRequest(r, *registry_, limits_);
  ASSERT_TRUE(spec.ok()) << spec.status();
  EXPECT_EQ(spec->options.first_column, 1);
  EXPECT_EQ(spec->options.columns, 10);  // [1, 11)
  EXPECT_EQ(spec->options.first_row, 0);
  EXPECT_EQ(spec->options.rows, 2);
  EXPECT_EQ(spec->cells, 5 * 1);

  // With every heading bin, the work is 72 times the cells.
  r.clear_region();
  r.set_stride(10);
  r.set_max_over_headings(true);
  spec = ValidateRiskLayerRequest(r, *registry_, limits_);
  ASSERT_TRUE(spec.ok());
  EXPECT_EQ(spec->evaluations, 20 * 20 * 72);
  EXPECT_TRUE(std::isnan(spec->options.heading_rad));
  limits_.max_risk_layer_evaluations = 20 * 20 * 72 - 1;
  spec = ValidateRiskLayerRequest(r, *registry_, limits_);
  ASSERT_EQ(spec.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(spec.status().message(),
              HasSubstr("the risk layer of 20 x 20 cells (stride 10) needs 28800 configuration "
                        "risks (72 heading bins each)"));
  EXPECT_THAT(spec.status().message(), HasSubstr("--max_risk_layer_evaluations"));
  limits_ = RequestLimits{};

  // Refusals, each naming its field.
  struct Case {
    void (*change)(v1::GetRiskLayerRequest*);
    const char* message;
  };
  const Case cases[] = {
      {[](v1::GetRiskLayerRequest* q) { q->set_stride(5000); }, "stride has value 5000"},
      {[](v1::GetRiskLayerRequest* q) { q->set_stride(-1); }, "stride has value -1"},
      {[](v1::GetRiskLayerRequest* q) { q->set_height_agl_m(-5); }, "height_agl_m has value -5"},
      {[](v1::GetRiskLayerRequest* q) { q->set_height_agl_m(2e4); },
       "height_agl_m has value 20000"},
      {[](v1::GetRiskLayerRequest* q) { q->set_heading_rad(INFINITY); },
       "heading_rad has value inf"},
      {[](v1::GetRiskLayerRequest* q) { q->set_stride(201); }, "stride 201 is larger than the map"},
      {[](v1::GetRiskLayerRequest* q) {
         q->mutable_region()->set_x_min_m(5000);
         q->mutable_region()->set_x_max_m(6000);
         q->mutable_region()->set_y_max_m(10);
       },
       "region x in [5000, 6000], y in [0, 10] does not overlap map 'geo-city'"},
      {[](v1::GetRiskLayerRequest* q) { q->mutable_region()->set_x_min_m(NAN); },
       "region.x_min_m has value nan"},
      {[](v1::GetRiskLayerRequest* q) { q->mutable_region()->set_x_max_m(-1); },
       "it needs x_min_m < x_max_m"},
      {[](v1::GetRiskLayerRequest* q) { q->mutable_model_params()->set_mass_kg(0); }, "mass_kg"},
      {[](v1::GetRiskLayerRequest* q) {
         q->set_map("flat");
         q->mutable_region_wgs84()->set_north_lat_deg(1);
         q->mutable_region_wgs84()->set_east_lon_deg(1);
       },
       "region_wgs84: map 'flat' has no geo-reference"},
      {[](v1::GetRiskLayerRequest* q) { q->mutable_region_wgs84()->set_south_lat_deg(-95); },
       "region_wgs84.south_lat_deg has value -95"},
  };
  for (const Case& c : cases) {
    v1::GetRiskLayerRequest q;
    q.set_map("geo-city");
    c.change(&q);
    spec = ValidateRiskLayerRequest(q, *registry_, limits_);
    ASSERT_FALSE(spec.ok()) << c.message;
    EXPECT_EQ(spec.status().code(), absl::StatusCode::kInvalidArgument) << c.message;
    EXPECT_THAT(spec.status().message(), HasSubstr(c.message));
  }
  r.set_map("nowhere");
  EXPECT_EQ(ValidateRiskLayerRequest(r, *registry_, limits_).status().code(),
            absl::StatusCode::kNotFound);
}

TEST_F(Wgs84ApiTest, ARiskLayerRegionInWgs84CoversItsBox) {
  const geo::GeoPose sw = Geo(1500, 0, 0, 0), ne = Geo(2000, 600, 0, 0);
  v1::GetRiskLayerRequest r;
  r.set_map("geo-city");
  r.mutable_region_wgs84()->set_south_lat_deg(sw.lat_deg);
  r.mutable_region_wgs84()->set_west_lon_deg(sw.lon_deg);
  r.mutable_region_wgs84()->set_north_lat_deg(ne.lat_deg);
  r.mutable_region_wgs84()->set_east_lon_deg(ne.lon_deg);
  absl::StatusOr<RiskLayerSpec> spec = ValidateRiskLayerRequest(r, *registry_, limits_);
  ASSERT_TRUE(spec.ok()) << spec.status();
  // The box's local extent reaches a little past the two corners (its
  // edges are not local lines), never short of them.
  EXPECT_LE(spec->options.first_column, 50);
  EXPECT_GE(spec->options.first_column, 48);
  EXPECT_GE(spec->options.first_column + spec->options.columns, 100);
  EXPECT_LE(spec->options.first_column + spec->options.columns, 102);
  EXPECT_LE(spec->options.first_row, 50);
  EXPECT_GE(spec->options.first_row + spec->options.rows, 110);
}

TEST_F(Wgs84ApiTest, MapInfoCarriesBothFrames) {
  const RiskMap& map = *registry_->Find("geo-city");
  const v1::MapInfo info = MapInfoFromMap(map, frame_.get());
  EXPECT_EQ(info.geo().origin_lat_deg(), kLat0);
  EXPECT_EQ(info.geo().origin_x_m(), 1000.0);
  EXPECT_EQ(info.geo().origin_y_m(), -500.0);
  EXPECT_THAT(info.geo().proj_definition(), HasSubstr("+proj=aeqd"));
  ASSERT_EQ(info.bounds_wgs84().corners_size(), 4);
  EXPECT_DOUBLE_EQ(info.bounds_wgs84().corners(0).lat_deg(), kLat0);
  EXPECT_DOUBLE_EQ(info.bounds_wgs84().corners(0).lon_deg(), kLon0);
  const geo::GeoPose ne = Geo(3000, 1500, 0, 0);
  EXPECT_DOUBLE_EQ(info.bounds_wgs84().corners(2).lat_deg(), ne.lat_deg);
  EXPECT_DOUBLE_EQ(info.bounds_wgs84().corners(2).lon_deg(), ne.lon_deg);
  EXPECT_LE(info.bounds_wgs84().min_lat_deg(), kLat0);
  EXPECT_GE(info.bounds_wgs84().max_lat_deg(), ne.lat_deg);
  ASSERT_EQ(info.landing_sites_size(), 1);
  const geo::GeoPose site = Geo(1205, -195, 0, 0);  // the centre of cell (20, 30)
  EXPECT_DOUBLE_EQ(info.landing_sites(0).wgs84().lat_deg(), site.lat_deg);
  EXPECT_DOUBLE_EQ(info.landing_sites(0).wgs84().lon_deg(), site.lon_deg);

  const v1::MapInfo flat = MapInfoFromMap(*registry_->Find("flat"), nullptr);
  EXPECT_FALSE(flat.has_geo());
  EXPECT_FALSE(flat.has_bounds_wgs84());
  EXPECT_FALSE(flat.landing_sites_size() > 0 && flat.landing_sites(0).has_wgs84());
}

TEST_F(Wgs84ApiTest, TrajectoriesCarryBothFramesAndTheirRiskPerFlightHour) {
  PlanImprovement improvement;
  improvement.waypoints = {{1100, -400, 200, 0.2}, {2000, 500, 210, 1.0}};
  improvement.risk = 3.6e-7;
  improvement.length_m = 1800.0;  // 100 s at 18 m/s
  v1::Trajectory t;
  ASSERT_TRUE(TrajectoryToProto(improvement, ModelParams{}, 25.0, frame_.get(), &t).ok());
  EXPECT_DOUBLE_EQ(t.flight_time_s(), 100.0);
  EXPECT_DOUBLE_EQ(t.risk_per_flight_hour(), 3.6e-7 * 36.0);
  ASSERT_EQ(t.waypoints_wgs84_size(), t.waypoints_size());
  ASSERT_EQ(t.path_wgs84_size(), t.path_size());
  for (int k = 0; k < t.path_size(); k += 7) {
    const geo::GeoPose g = Geo(t.path(k).x(), t.path(k).y(), t.path(k).z(), t.path(k).theta());
    EXPECT_EQ(t.path_wgs84(k).lat_deg(), g.lat_deg) << k;
    EXPECT_EQ(t.path_wgs84(k).lon_deg(), g.lon_deg) << k;
    EXPECT_EQ(t.path_wgs84(k).alt_m(), t.path(k).z()) << k;
    EXPECT_EQ(t.path_wgs84(k).heading_deg(), g.heading_deg) << k;
  }
  // Without a frame, the local frame only.
  ASSERT_TRUE(TrajectoryToProto(improvement, ModelParams{}, 25.0, nullptr, &t).ok());
  EXPECT_EQ(t.waypoints_wgs84_size(), 0);
  EXPECT_EQ(t.path_wgs84_size(), 0);

  // A trajectory of length 0 has no risk per hour.
  EXPECT_EQ(RiskPerFlightHour(0.0, FlightTimeS(0.0, 18.0)), 0.0);
}

TEST_F(Wgs84ApiTest, EvaluationsCarryBothFramesWhereTheyCan) {
  TrajectoryEvaluation evaluation;
  evaluation.risk = 1e-7;
  evaluation.length_m = 900.0;
  // The answer reports the evaluation's own time (EvaluateTrajectory's: length / v
  // in still air, as here), not one recomputed from the length.
  evaluation.flight_time_s = FlightTimeS(900.0, 20.0);
  evaluation.admissible = false;
  evaluation.first_violation =
      Violation{ViolationKind::kOutsideMap, {1e9, 0, 200, 0}, 10.0, 0, std::nan("")};
  SampleEvaluation inside;
  inside.pose = {1500, 500, 200, 1.0};
  SampleEvaluation far = inside;
  far.pose.x = 1e9;  // a sample of a polyline the client sent far away
  evaluation.samples = {inside, far};
  ModelParams params;
  params.airspeed_mps = 20.0;
  v1::EvaluateRiskResponse r;
  EvaluationToProto(evaluation, params, true, frame_.get(), &r);
  EXPECT_EQ(r.flight_time_s(), 45.0);
  EXPECT_EQ(r.airspeed_mps(), 20.0);
  EXPECT_DOUBLE_EQ(r.risk_per_flight_hour(), 1e-7 * 80.0);
  ASSERT_EQ(r.samples_size(), 2);
  EXPECT_TRUE(r.samples(0).has_wgs84());
  EXPECT_FALSE(r.samples(1).has_wgs84());  // beyond the frame: local only
  EXPECT_FALSE(r.first_violation().has_pose_wgs84());
}

TEST_F(Wgs84ApiTest, RiskLayerResponse) {
  RiskLayer layer;
  layer.nx = 2;
  layer.ny = 1;
  layer.x0 = 1010;
  layer.y0 = -500;
  layer.res_m = 20;
  layer.risk = {1e-6, std::nan("")};
  layer.evaluations = 144;
  RiskLayerOptions options;
  options.stride = 2;
  options.first_column = 1;
  options.height_agl_m = 70;
  options.heading_rad = std::nan("");
  const v1::GetRiskLayerResponse r =
      RiskLayerToProto(layer, *registry_->Find("geo-city"), options, frame_.get());
  EXPECT_EQ(r.nx(), 2);
  EXPECT_EQ(r.first_column(), 1);
  EXPECT_EQ(r.cell_m(), 20);
  EXPECT_TRUE(r.max_over_headings());
  ASSERT_EQ(r.risk_size(), 2);
  EXPECT_TRUE(std::isnan(r.risk(1)));
  ASSERT_EQ(r.bounds_wgs84().corners_size(), 4);
  const geo::GeoPose sw = Geo(1010, -500, 0, 0);
  EXPECT_DOUBLE_EQ(r.bounds_wgs84().corners(0).lon_deg(), sw.lon_deg);
}

// A wind from true north becomes the grid direction with the convergence at
// the map's centre, and the answer echoes both; a map without geo-reference
// takes only the local form.
TEST_F(Wgs84ApiTest, AWindFromTrueNorthTurnsByTheGridConvergence) {
  absl::StatusOr<double> gamma = frame_->GridConvergenceRad({2000.0, 500.0});  // the centre
  ASSERT_TRUE(gamma.ok()) << gamma.status();
  const double gamma_deg = *gamma / kDeg;
  EXPECT_GT(std::fabs(gamma_deg), 1e-3);  // east of the origin's meridian: it matters
  v1::EvaluateRiskRequest e;
  e.set_map("geo-city");
  v1::Point3* p = e.mutable_polyline()->add_points();
  p->set_x(1200);
  p->set_y(500);
  p->set_z(200);
  p = e.mutable_polyline()->add_points();
  p->set_x(2800);
  p->set_y(500);
  p->set_z(200);
  e.mutable_wind_wgs84()->mutable_from()->set_speed_mps(6);
  e.mutable_wind_wgs84()->mutable_from()->set_from_deg(450);  // 90: modulo 360
  absl::StatusOr<EvaluateSpec> spec = ValidateEvaluateRequest(e, *registry_, limits_);
  ASSERT_TRUE(spec.ok()) << spec.status();
  EXPECT_EQ(spec->params.wind_speed_mps, 6.0);
  EXPECT_NEAR(spec->params.wind_from_deg, 90.0 - gamma_deg, 1e-12);
  EXPECT_NEAR(spec->wind.from_deg(), 90.0 - gamma_deg, 1e-12);
  ASSERT_TRUE(spec->wind.has_from_true_deg());
  EXPECT_NEAR(spec->wind.from_true_deg(), 90.0, 1e-12);
  // An east wind blows west: the vector is (-6, 0) turned by the convergence.
  EXPECT_NEAR(spec->wind.x_mps(), -6.0 * std::cos(*gamma), 1e-9);
  EXPECT_NEAR(spec->wind.y_mps(), -6.0 * std::sin(*gamma), 1e-9);

  // The same in local terms needs no frame; on the map without one the
  // WGS84 form is refused naming the field and the map.
  e.set_map("flat");
  absl::StatusOr<EvaluateSpec> refused = ValidateEvaluateRequest(e, *registry_, limits_);
  ASSERT_FALSE(refused.ok());
  EXPECT_THAT(refused.status().message(), HasSubstr("wind_wgs84: map 'flat' has no geo-reference"));
  e.mutable_wind()->mutable_from()->set_speed_mps(6);
  e.mutable_wind()->mutable_from()->set_from_deg(90);
  absl::StatusOr<EvaluateSpec> local = ValidateEvaluateRequest(e, *registry_, limits_);
  ASSERT_TRUE(local.ok()) << local.status();
  EXPECT_EQ(local->params.wind_from_deg, 90.0);
  EXPECT_FALSE(local->wind.has_from_true_deg());
}

}  // namespace
}  // namespace riskplan::server
