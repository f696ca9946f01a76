// The options of the `riskplan` commands, parsed from flags by
// riskplan_main.cc (and, mission by mission, from a missions file by
// fleet_file.h). A plain struct of its own, so that the missions file and the
// commands can both use it without including each other.
#ifndef RISKPLAN_CLIENT_CLI_COMMAND_OPTIONS_H_
#define RISKPLAN_CLIENT_CLI_COMMAND_OPTIONS_H_

#include <cstdint>
#include <string>

#include "absl/time/time.h"
#include "client/client.h"
#include "client/exports.h"

namespace riskplan::client {

struct CliOptions {
  std::string server;
  ConnectionOptions connection;  // TLS and token (--tls_*, --token_file)
  std::string map = "demo-city";
  absl::Duration timeout = absl::ZeroDuration();  // zero: the command's default
  bool json = false;

  // Trajectory input (eval, load --rpc=eval).
  std::string waypoints;
  std::string polyline;
  std::string trajectory_file;
  bool samples = false;
  std::string params;  // model parameters "name=value,..."
  std::string wind;    // "SPEED@FROM_DEG" or "wgs84:SPEED@FROM_DEG"; empty: none (eval, plan)
  // Two-tier feasibility check (eval).
  bool two_tier = false;
  std::string two_tier_rule = "FLIGHT_BAND";  // FLIGHT_BAND | TERRAIN_ONLY
  int two_tier_detailed_segments = -1;        // -1: unset (server default)
  int two_tier_block_cells = -1;              // -1: unset (server default)
  bool two_tier_bresenham = false;

  // Planning (plan, load --rpc=plan).
  std::string start;
  std::string goal;
  std::string algorithm = "RISK_RRT_STAR";
  int64_t budget_ms = 5000;
  int64_t iterations = 0;
  uint64_t seed = 1;
  std::string planner_params;  // "name=value,..."
  std::string obstacles;       // point obstacles "x,y; x,y; ..."
  int64_t min_update_interval_ms = 100;
  double display_step_m = 25.0;
  bool tree = false;
  std::string picture;         // .svg or .png
  int picture_size = 800;      // largest side, pixels (map cells after downsampling)
  std::string trajectory_out;  // JSON of the best trajectory's waypoints
  // Limits (PlanRequest.limits; 0: none) and objective (plan, fleet).
  double max_flight_time_s = 0.0;
  double max_length_m = 0.0;
  double max_risk = 0.0;
  double max_risk_per_flight_hour = 0.0;
  std::string objective = "MIN_RISK";  // MIN_RISK | MIN_TIME
  bool pareto = false;
  // A QGroundControl mission to plan leg by leg, and where to write it back
  // planned (plan).
  std::string mission;
  std::string mission_out;

  // Ground-station and GIS files of the trajectory (plan, eval), written
  // from the server's path sampled every exports.spacing_m.
  ExportFiles exports;
  std::string plan_firmware = "px4";  // px4 | ardupilot | generic (the .plan's firmwareType)
  // Target level of safety, expected casualties per flight hour (plan, eval).
  double target_level_of_safety = 1e-6;

  // Fleet (fleet, load --rpc=fleet): the missions file (client/cli/fleet_file.h).
  std::string missions;
  // Re-submissions of missions a broken stream left without a result (fleet).
  int max_resubmits = 3;

  // Fly: the scripted flight (client/cli/fly_command.cc).
  std::string scenario;

  // Load.
  std::string rpc = "eval";     // eval | plan | fleet | ping
  std::string mode = "closed";  // closed | open
  int concurrency = 8;
  double rate = 100.0;
  double duration_s = 10.0;
  int max_outstanding = 10000;
  bool ceiling = false;
  std::string report_json;
};

}  // namespace riskplan::client

#endif  // RISKPLAN_CLIENT_CLI_COMMAND_OPTIONS_H_
