// The page's QGroundControl missions (docs/web.md, "Missions"): a .plan
// uploaded by a browser is read by geo/export's ParseQgcPlan (the one .plan
// reader, as `riskplan plan --mission` reads it) and cut into legs by the
// client library's mission functions (client/mission.h); the gateway adds
// only what is the page's: the upload's size bound, the limits a .plan may
// carry in its "riskplan" section, and the JSON the page fills its form from.
#ifndef RISKPLAN_WEB_MISSION_FILE_H_
#define RISKPLAN_WEB_MISSION_FILE_H_

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "client/mission.h"
#include "geo/export/qgc_mission.h"
#include "riskplan/v1/planner.pb.h"

namespace riskplan::web {

// The largest .plan the gateway reads: a mission of hundreds of items is some
// 100 kB; riskplan's own written-back missions (a waypoint every 25 m) some
// 200 kB for 10 km.
inline constexpr size_t kMaxMissionFileBytes = size_t{2} << 20;

// A mission as the gateway plans it.
struct WebMission {
  geo::QgcMission mission;
  std::vector<double> headings_deg;       // per point (client::MissionHeadings)
  std::vector<client::MissionLeg> legs;   // point k to point k + 1
  // The whole mission's limits from the file's "riskplan" section
  // ({"limits": FlightLimits in the API's JSON form}), when it has them.
  bool has_limits = false;
  v1::FlightLimits limits;
};

// Reads an uploaded .plan. InvalidArgument: larger than
// kMaxMissionFileBytes ("the .plan is N bytes; ..."), ParseQgcPlan's own
// errors (naming the item), or "riskplan.limits" that are not FlightLimits.
absl::StatusOr<WebMission> ReadMissionFile(std::string_view text);

// The mission for the page (one line of JSON): {"home": {lat_deg, lon_deg,
// alt_m}, "cruise_speed_mps", "points": [{"item", "kind", "name", "lat_deg",
// "lon_deg", "alt_m", "heading_deg", "heading_given"}], "legs": [{"from",
// "to", "name", "start": GeoPose, "goal": GeoPose}], and "limits"
// (FlightLimits) when the file has them.
std::string MissionJson(const WebMission& mission);

// "leg 2 (mission item 1 (waypoint) -> mission item 2 (land))", leg from 0.
std::string LegName(const WebMission& mission, size_t leg);

// A refusal of a leg's start or goal by the server, naming the mission item
// instead of "start_wgs84"/"goal_wgs84" and keeping the server's words, as
// `riskplan plan --mission` says it: "mission item 3 (land) at (49.6140000,
// 6.1230000, 200.0 m): goal_wgs84 ...".
std::string LegEndpointError(const WebMission& mission, size_t leg, const std::string& message);

// `plan_json` (a .plan written by geo::QgcMissionPlanJson) with the limits
// in its "riskplan" section, so that the page reads them back with the
// mission. InvalidArgument when `plan_json` is not such a file.
absl::StatusOr<std::string> WithMissionLimits(std::string_view plan_json,
                                              const v1::FlightLimits& limits);

}  // namespace riskplan::web

#endif  // RISKPLAN_WEB_MISSION_FILE_H_
