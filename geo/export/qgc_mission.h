// A mission read from a QGroundControl plan file (.plan, JSON; the developer
// guide's "Plan File Format"), and a planned mission written back as one.
//
// What is read, item by item (docs/geodata.md, "Missions from QGroundControl",
// has the same table):
//   16 NAV_WAYPOINT      a waypoint to pass: its position, and its yaw
//                        (param 4, degrees clockwise from north) as the
//                        heading to pass it at when it is a number (null or
//                        NaN: riskplan chooses the heading);
//   22 NAV_TAKEOFF       where the mission starts (its position, or home
//                        when latitude and longitude are both 0);
//   21 NAV_LAND          where it ends (its position, or home when 0, 0);
//   20 NAV_RETURN_TO_LAUNCH  it ends over home;
//   189 DO_LAND_START, 206 DO_SET_CAM_TRIGG_DIST, 203 DO_DIGICAM_CONTROL,
//   2000 IMAGE_START_CAPTURE, 2001 IMAGE_STOP_CAPTURE, 183 DO_SET_SERVO,
//   201 DO_SET_ROI, 195 DO_SET_ROI_LOCATION, 197 DO_SET_ROI_NONE,
//   530 SET_CAMERA_MODE, 1000 DO_GIMBAL_MANAGER_PITCHYAW
//                        passed through unchanged: they do not move the
//                        aircraft, and are written back after the waypoint
//                        they followed;
// anything else (loiters, DO_JUMP, speed changes, VTOL items, complex items
// such as surveys, geofences the planner would have to honour) is refused
// with an error naming the item: riskplan cannot plan what it does.
// Altitude frames: 0 (global, AMSL) and 3 (relative to home), and their
// integer variants 5 and 6; 10 and 11 (above terrain) are refused.
//
// Plain values and nlohmann-json only, like the writers of qgc_plan.h, so
// that the client shares them.
#ifndef RISKPLAN_GEO_EXPORT_QGC_MISSION_H_
#define RISKPLAN_GEO_EXPORT_QGC_MISSION_H_

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "geo/export/export_trajectory.h"

namespace riskplan::geo {

inline constexpr int kMavCmdNavTakeoff = 22;
inline constexpr int kMavCmdNavLand = 21;
inline constexpr int kMavCmdNavReturnToLaunch = 20;

// The most items a .plan may hold (QGroundControl's own missions stay in the
// hundreds; a bound keeps a hostile file from costing unbounded work).
inline constexpr size_t kMaxQgcItems = 10000;

enum class MissionPointKind { kTakeoff, kWaypoint, kLand, kReturnToLaunch };

// "takeoff", "waypoint", "land", "return to launch".
std::string_view MissionPointKindName(MissionPointKind kind);

// A place the mission must pass, in WGS84 with its altitude AMSL (frames
// resolved against the home position).
struct MissionPoint {
  MissionPointKind kind = MissionPointKind::kWaypoint;
  double lat_deg = 0.0;
  double lon_deg = 0.0;
  double alt_m = 0.0;  // AMSL
  // Heading to pass it at, degrees clockwise from true north; none: free.
  std::optional<double> heading_deg;
  size_t item = 0;  // index of its item in the file's mission.items, from 0
  std::string item_json;  // the item as read (written back for the mission's own points)
  // Items passed through unchanged after this one (as JSON text).
  std::vector<std::string> following;
};

struct QgcMission {
  double home_lat_deg = 0.0;
  double home_lon_deg = 0.0;
  double home_alt_m = 0.0;  // AMSL
  double cruise_speed_mps = 0.0;  // 0 when the file has none
  int firmware_type = 0;
  int vehicle_type = 0;
  // Items passed through that came before the first point.
  std::vector<std::string> leading;
  // In order: an optional takeoff, the waypoints, an optional land or
  // return-to-launch. At least two points in all (a start and an end).
  std::vector<MissionPoint> points;
};

// Parses a .plan. InvalidArgument naming what is wrong and where: not JSON
// (with the parser's byte offset), a missing or wrong fileType or version,
// an item that cannot be planned ("mission item 3 (doJumpId 4): command 19
// (NAV_LOITER_TIME) cannot be planned by riskplan; ..."), a position out of
// WGS84's range, fewer than two points. A file that riskplan wrote for a
// planned mission (its "riskplan" section lists which items were the
// mission's own) reads back as that mission, not as every point of the
// route.
absl::StatusOr<QgcMission> ParseQgcPlan(std::string_view text);

// A planned mission as a .plan: the mission's home, its takeoff item (as
// read), then for each leg the route's samples as NAV_WAYPOINT items at
// absolute altitude followed by the mission's own item for the point the leg
// ends at (as read, with the planned position) and the items that followed
// it, ending with the land or return item. `leg_end_sample[i]` is the index in
// `route.samples` of mission point i + 1 (point 0 is the first sample).
// cruiseSpeed is route.airspeed_mps. A top-level "riskplan" section records
// the doJumpIds of the mission's own items, so that ParseQgcPlan of the
// result gives back the same mission. InvalidArgument when the sizes do not
// agree or the route cannot be written (CheckExportTrajectory).
absl::StatusOr<std::string> QgcMissionPlanJson(const QgcMission& mission,
                                               const ExportTrajectory& route,
                                               const std::vector<size_t>& leg_end_sample);

}  // namespace riskplan::geo

#endif  // RISKPLAN_GEO_EXPORT_QGC_MISSION_H_
