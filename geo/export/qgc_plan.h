// QGroundControl's plan file (.plan, JSON), as its developer guide documents
// it ("Plan File Format"): a mission of NAV_WAYPOINT items, one per sample of
// the flown path, at absolute (AMSL) altitudes, for a fixed-wing aircraft.
//
// The file written, field by field:
//   fileType "Plan", version 1, groundStation "riskplan";
//   mission: version 2, firmwareType (MAV_AUTOPILOT), vehicleType 1
//     (MAV_TYPE_FIXED_WING), cruiseSpeed (the model's airspeed, m/s),
//     hoverSpeed (unused by a fixed wing), globalPlanAltitudeMode 2
//     (absolute), plannedHomePosition [lat, lon, alt AMSL] (the start's
//     position on the ground: the terrain under it, or its altitude when the
//     terrain is unknown), items;
//   each item: type "SimpleItem", command 16 (MAV_CMD_NAV_WAYPOINT), frame 0
//     (MAV_FRAME_GLOBAL: WGS84, altitude AMSL), params [hold s, acceptance
//     radius m, pass radius m, yaw (null: NaN, the vehicle keeps its own yaw
//     mode; a fixed wing flies along the path), lat, lon, alt AMSL],
//     autoContinue true, doJumpId 1, 2, ... in order, AltitudeMode 2
//     (absolute), Altitude (alt AMSL), AMSLAltAboveTerrain null (only used in
//     QGroundControl's terrain modes);
//   geoFence {version 2, circles [], polygons []}; rallyPoints {version 2,
//     points []}.
// The mission starts in the air where the trajectory starts: take-off and
// landing items are the operator's to add.
#ifndef RISKPLAN_GEO_EXPORT_QGC_PLAN_H_
#define RISKPLAN_GEO_EXPORT_QGC_PLAN_H_

#include <string>

#include "absl/status/statusor.h"
#include "geo/export/export_trajectory.h"

namespace riskplan::geo {

// MAVLink constants the file uses.
inline constexpr int kMavCmdNavWaypoint = 16;
inline constexpr int kMavFrameGlobal = 0;  // WGS84, altitude above mean sea level
inline constexpr int kMavTypeFixedWing = 1;
inline constexpr int kMavAutopilotGeneric = 0;
inline constexpr int kMavAutopilotArdupilotMega = 3;
inline constexpr int kMavAutopilotPx4 = 12;
// QGroundControl's AltitudeModeAbsolute (QGroundControlQmlGlobal::AltMode).
inline constexpr int kQgcAltitudeModeAbsolute = 2;

struct QgcPlanOptions {
  int firmware_type = kMavAutopilotPx4;  // MAV_AUTOPILOT of the mission
  double hold_s = 0.0;                   // param1: time at each waypoint
  double acceptance_radius_m = 0.0;      // param2: 0, the autopilot's own default
  double pass_radius_m = 0.0;            // param3: 0, pass through the waypoint
  double hover_speed_mps = 5.0;          // QGroundControl's default; a fixed wing ignores it
};

// The .plan text (2-space indented JSON, every number as the shortest
// decimal that reads back to the same double) of `trajectory`, one waypoint
// per sample. InvalidArgument when CheckExportTrajectory refuses it, or the
// options are not finite and >= 0.
absl::StatusOr<std::string> QgcPlanJson(const ExportTrajectory& trajectory,
                                        const QgcPlanOptions& options = {});

// "px4" (12), "ardupilot" (3) or "generic" (0) as a MAV_AUTOPILOT value;
// InvalidArgument naming the known names otherwise.
absl::StatusOr<int> FirmwareTypeFromName(const std::string& name);

}  // namespace riskplan::geo

#endif  // RISKPLAN_GEO_EXPORT_QGC_PLAN_H_
