// QGroundControl .plan documents for the tests of missions (the CLI's, the
// web gateway's): a SimpleItem at a WGS84 position, and the whole plan file
// around a home position and its items, as QGroundControl writes them
// (docs/geodata.md, "QGroundControl missions").
#ifndef RISKPLAN_TESTS_QGC_PLAN_TESTING_H_
#define RISKPLAN_TESTS_QGC_PLAN_TESTING_H_

#include "nlohmann/json.hpp"

namespace riskplan::testing_qgc {

// A mission item `command` (22 takeoff, 16 waypoint, 21 land) numbered `id`
// at (lat, lon), altitude AMSL (frame 0).
inline nlohmann::json SimpleItem(int command, int id, double lat_deg, double lon_deg,
                                 double alt_m) {
  return nlohmann::json{
      {"type", "SimpleItem"},
      {"command", command},
      {"frame", 0},
      {"doJumpId", id},
      {"autoContinue", true},
      {"params", nlohmann::json::array({0, 0, 0, nullptr, lat_deg, lon_deg, alt_m})}};
}

// A plan file (version 1, mission version 2, cruise speed 18 m/s) with its
// planned home at (lat, lon, alt AMSL), these items, no fence and no rally points.
inline nlohmann::json PlanDocument(double home_lat_deg, double home_lon_deg, double home_alt_m,
                                   nlohmann::json items) {
  using Json = nlohmann::json;
  return Json{
      {"fileType", "Plan"},
      {"version", 1},
      {"groundStation", "QGroundControl"},
      {"mission",
       {{"version", 2},
        {"firmwareType", 12},
        {"vehicleType", 1},
        {"cruiseSpeed", 18},
        {"hoverSpeed", 5},
        {"plannedHomePosition", Json::array({home_lat_deg, home_lon_deg, home_alt_m})},
        {"items", std::move(items)}}},
      {"geoFence", {{"version", 2}, {"circles", Json::array()}, {"polygons", Json::array()}}},
      {"rallyPoints", {{"version", 2}, {"points", Json::array()}}}};
}

}  // namespace riskplan::testing_qgc

#endif  // RISKPLAN_TESTS_QGC_PLAN_TESTING_H_
