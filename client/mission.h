// Missions with waypoints in the client (`riskplan plan --mission=FILE.plan`,
// issue 35): the legs of a QGroundControl mission (geo/export/qgc_mission.h),
// the headings riskplan chooses where the mission leaves them free, the share
// of the whole mission's limits each leg gets, and the legs' sampled paths
// joined into one route for the writers. Plain values: the planning calls
// are client/cli/mission_command.cc's.
#ifndef RISKPLAN_CLIENT_MISSION_H_
#define RISKPLAN_CLIENT_MISSION_H_

#include <cstddef>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "geo/export/export_trajectory.h"
#include "geo/export/qgc_mission.h"
#include "riskplan/v1/planner.pb.h"

namespace riskplan::client {

// "mission item 3 (waypoint)": how every message names a point of the mission.
std::string MissionItemName(const geo::MissionPoint& point);

// Initial great-circle bearing from (lat1, lon1) to (lat2, lon2), degrees
// clockwise from true north in [0, 360).
double InitialBearingDeg(double lat1_deg, double lon1_deg, double lat2_deg, double lon2_deg);

// Great-circle distance on a sphere of the WGS84 mean radius, with the
// altitude difference: sqrt(d^2 + dz^2), m. Used only to share limits among
// legs.
double LegDistanceM(const geo::MissionPoint& a, const geo::MissionPoint& b);

// The heading of each mission point, degrees clockwise from true north: the
// item's own when it gives one; otherwise the bisector of the bearing in
// (from the point before) and the bearing out (to the point after), the
// bearing out at the first point and the bearing in at the last (the
// direction of the mission there, so that no leg starts or ends with a
// needless turn). Where in and out are opposite, the bearing out.
std::vector<double> MissionHeadings(const geo::QgcMission& mission);

// The start and goal of every leg (point k to point k + 1), in WGS84.
struct MissionLeg {
  size_t from = 0;  // index in mission.points
  size_t to = 0;
  v1::GeoPose start;
  v1::GeoPose goal;
};
std::vector<MissionLeg> MissionLegs(const geo::QgcMission& mission,
                                    const std::vector<double>& headings_deg);

// What the mission has used so far (the legs planned before).
struct MissionUsed {
  double flight_time_s = 0.0;
  double length_m = 0.0;
  double risk = 0.0;
};

// The limits of the leg `leg` of `legs` given the whole mission's `whole` and
// what the legs before used: the remaining endurance, length and per-flight
// risk shared among the remaining legs in proportion to LegDistanceM (so the
// whole mission stays within them whatever each leg uses below its share);
// the per-hour target as it is (legs each within it keep the mission within
// it: the risks and the hours add up); objective as it is; no front. A limit
// already used up becomes the smallest positive value, so that
// the leg fails with the limit's note.
v1::FlightLimits LegLimits(const v1::FlightLimits& whole, const MissionUsed& used,
                           const geo::QgcMission& mission, const std::vector<MissionLeg>& legs,
                           size_t leg);

// The legs' sampled paths (each EvaluateRisk's path, start to goal) joined
// into one route: the first sample of each leg after the first is the last of
// the leg before and is dropped; arc lengths run on. `leg_end_sample[i]` is
// the index of the route's sample at the end of leg i (mission point i + 1),
// as QgcMissionPlanJson takes it. The totals (risk, length, flight time)
// are left for the caller to set from an evaluation of the whole mission.
// InvalidArgument when there are no legs or a leg has fewer than 2 samples.
struct JoinedRoute {
  geo::ExportTrajectory route;
  std::vector<size_t> leg_end_sample;
};
absl::StatusOr<JoinedRoute> JoinLegs(const std::vector<geo::ExportTrajectory>& legs);

}  // namespace riskplan::client

#endif  // RISKPLAN_CLIENT_MISSION_H_
