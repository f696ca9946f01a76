// Temporary no-fly zones of an in-flight session (proto FlightZone): checked
// from the API message into a FlightZoneSpec, tested against poses, and
// closed on a copy of the map's no-fly layer.
//
// A zone acts like the map's no-fly cells: every cell whose centre lies
// within half a cell diagonal of the zone's area is closed (so a sample in
// the zone always lies in a closed cell), for flight, gliding and landing.
// The planner and a route's admissibility close the zone's whole column; its
// altitude band, when it has one, is honoured only by InsideZone (is the
// aircraft in it?). docs/in-flight.md says why.
#ifndef RISKPLAN_SERVER_FLIGHT_FLIGHT_ZONES_H_
#define RISKPLAN_SERVER_FLIGHT_FLIGHT_ZONES_H_

#include <cstddef>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/map/risk_map.h"
#include "riskplan/v1/planner.pb.h"

namespace riskplan::server {

// Bounds of a session's zones (set from the server's flags).
struct ZoneLimits {
  size_t max_zones = 64;           // zones known to a session at once
  size_t max_vertices = 64;        // vertices of one polygon
  double max_radius_m = 50000.0;   // radius of a circle
  size_t max_id_chars = 64;
};

struct ZoneVertex2 {
  double x = 0.0;
  double y = 0.0;
};

struct FlightZoneSpec {
  std::string id;
  bool is_circle = false;
  ZoneVertex2 centre;                // circle
  double radius_m = 0.0;             // circle
  std::vector<ZoneVertex2> polygon;  // polygon, >= 3 vertices, simple
  std::optional<double> min_alt_m;
  std::optional<double> max_alt_m;
  double valid_from_s = 0.0;
  double valid_until_s = 0.0;  // 0: for ever

  bool ActiveAt(double time_s) const {
    return time_s >= valid_from_s && (valid_until_s == 0.0 || time_s < valid_until_s);
  }
  // Whether (x, y) lies in the zone's area (boundary included).
  bool ContainsXY(double x, double y) const;
  // Whether the pose lies in the zone: its area and its band, if any.
  bool Contains(const Pose& pose) const;
  // Distance from (x, y) to the zone's area (0 inside).
  double DistanceXY(double x, double y) const;
};

// Checks a zone: id of 1..max_id_chars characters, a shape (circle with a
// finite centre and a radius in (0, max_radius_m], or a polygon of 3..
// max_vertices finite vertices, of non-zero area, no two edges crossing),
// a band with finite min < max when either is set (both must be), a finite
// validity interval with valid_until_s = 0 or > valid_from_s >= 0.
// InvalidArgument naming `field` and the offending part, e.g.
// "add_zone.polygon.vertices: edges 0 and 2 cross (the polygon intersects itself)".
absl::StatusOr<FlightZoneSpec> ZoneFromProto(const v1::FlightZone& zone, const ZoneLimits& limits,
                                             std::string_view field);

// True when segments [a, b] and [c, d] share a point.
bool SegmentsIntersect(ZoneVertex2 a, ZoneVertex2 b, ZoneVertex2 c, ZoneVertex2 d);

// Closes, in `nofly` (the map's layer, nx*ny), every cell of `map` whose
// centre lies within half a cell diagonal of the zone's area. Returns the
// number of cells it closed that were open.
int64_t CloseZoneCells(const RiskMap& map, const FlightZoneSpec& zone, std::vector<uint8_t>* nofly);

// `map`'s no-fly layer with every zone of `zones` closed; *closed (when
// given) the number of cells the zones closed that were open.
std::vector<uint8_t> NoFlyWithZones(const RiskMap& map,
                                    const std::vector<const FlightZoneSpec*>& zones,
                                    int64_t* closed = nullptr);

// `map` with every zone of `zones` closed as well: RiskMap::WithNoFly of
// NoFlyWithZones, which shares `map`'s other layers and repairs its glide
// layer for the closed cells only. `map` itself when the zones close no
// open cell.
absl::StatusOr<std::shared_ptr<const RiskMap>> MapWithZones(
    const std::shared_ptr<const RiskMap>& map, const std::vector<const FlightZoneSpec*>& zones);

}  // namespace riskplan::server

#endif  // RISKPLAN_SERVER_FLIGHT_FLIGHT_ZONES_H_
