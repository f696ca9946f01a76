// riskplan: the command-line client of riskplan-server.
//
// Only flags and the help live here. The commands (commands.h) take their options
// as a plain CliOptions struct, never reading flags themselves, so that they
// carry no global state and could be driven from other code as well.
#include <cstdio>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "client/cli/commands.h"
#include "client/connection_flags.h"
#include "cmdline/help.h"

ABSL_FLAG(std::string, server, "127.0.0.1:50051",
          "riskplan-server address: HOST:PORT, a list HOST:PORT,HOST:PORT,... of replicas, or a "
          "gRPC URI such as dns:///NAME:PORT (calls go round-robin over every address)");
ABSL_FLAG(std::string, map, "demo-city", "Map name (see `riskplan maps`)");
ABSL_FLAG(int64_t, timeout_ms, 0,
          "Deadline of each call, ms (0: 10 s for maps, 30 s for eval and load calls, none for "
          "plan)");
ABSL_FLAG(bool, json, false, "maps, eval: print the response as JSON");
ABSL_FLAG(std::string, waypoints, "",
          "eval, load: waypoints 'x,y,z,theta;...' (m, m, m AMSL, rad), joined by "
          "Dubins-airplane manoeuvres; or 'wgs84:lat,lon,alt,heading_deg;...' (deg, deg, m AMSL, "
          "deg clockwise from true north) on a geo-referenced map");
ABSL_FLAG(std::string, polyline, "",
          "eval, load: polyline 'x,y,z;...' of straight segments, or 'wgs84:lat,lon,alt;...'");
ABSL_FLAG(std::string, trajectory_file, "",
          "eval, load: JSON file {\"waypoints\": [[x,y,z,theta],...]} or {\"polyline\": "
          "[[x,y,z],...]} (docs/api.md, \"Trajectory files\")");
ABSL_FLAG(bool, samples, false, "eval: also print every sample's configuration risk");
ABSL_FLAG(bool, two_tier, false,
          "eval: also run the two-tier feasibility check and print which tier found the "
          "first collision");
ABSL_FLAG(std::string, two_tier_rule, "FLIGHT_BAND",
          "eval --two_tier: cell rule, FLIGHT_BAND (spec section 6) or TERRAIN_ONLY (seed 001)");
ABSL_FLAG(int, two_tier_detailed_segments, -1,
          "eval --two_tier: pieces checked on the detailed grid (-1: the server's default, 2)");
ABSL_FLAG(int, two_tier_block_cells, -1,
          "eval --two_tier: side of a coarse block, cells (-1: the server's default, 16)");
ABSL_FLAG(bool, two_tier_bresenham, false,
          "eval --two_tier: seed 001's one-cell-per-step traversal instead of every cell a "
          "segment touches");
ABSL_FLAG(std::string, params, "",
          "Model parameter overrides 'name=value,...' (names as in docs/risk-model.md, e.g. "
          "mass_kg=12,airspeed_mps=20)");
ABSL_FLAG(std::string, wind, "",
          "plan, eval, fleet: the mean wind, SPEED@FROM_DEG: m/s and the direction it blows "
          "from, degrees clockwise from the map's grid north (any finite value, taken modulo "
          "360; at most half the airspeed), e.g. 8@270 for a west wind; 'wgs84:SPEED@FROM_DEG' "
          "takes the direction from true north (a geo-referenced map). Empty: still air (or "
          "--params' wind_speed_mps, wind_from_deg)");
ABSL_FLAG(std::string, scenario, "",
          "fly: the scripted flight, a JSON file (FlightOpen, speed-up, report interval, timeline "
          "of zone and wind changes and stream breaks; docs/in-flight.md)");
ABSL_FLAG(double, max_flight_time_s, 0.0,
          "plan, fleet: endurance, s: no trajectory flying longer (at the ground speed in wind) "
          "is streamed or returned; 0: no limit");
ABSL_FLAG(double, max_length_m, 0.0, "plan, fleet: longest trajectory, m (3-D); 0: no limit");
ABSL_FLAG(double, max_risk, 0.0,
          "plan, fleet: target level of safety per flight, expected casualties; 0: no limit");
ABSL_FLAG(double, max_risk_per_flight_hour, 0.0,
          "plan, fleet: target level of safety per flight hour (risk / flight hours, e.g. 1e-6); "
          "0: no limit");
ABSL_FLAG(std::string, objective, "MIN_RISK",
          "plan, fleet: MIN_RISK (the lowest risk within the limits) or MIN_TIME (the quickest "
          "trajectory within the limits)");
ABSL_FLAG(bool, pareto, false,
          "plan, fleet: stream the front of non-dominated (risk, flight time) trajectories");
ABSL_FLAG(std::string, mission, "",
          "plan: a QGroundControl mission (.plan) to plan leg by leg instead of --start and "
          "--goal: its takeoff, waypoints and land or return (docs/geodata.md); the limits "
          "apply to the whole mission, --budget_ms to each leg");
ABSL_FLAG(std::string, mission_out, "",
          "plan --mission: write the planned mission back as a .plan QGroundControl opens");
ABSL_FLAG(std::string, start, "",
          "plan: start pose 'x,y,z,theta' (m, m, m AMSL, rad from east), or "
          "'wgs84:lat,lon,alt,heading_deg' (deg, deg, m AMSL, deg clockwise from true north) on a "
          "geo-referenced map");
ABSL_FLAG(std::string, goal, "",
          "plan: goal pose 'x,y,z,theta' or 'wgs84:lat,lon,alt,heading_deg'");
ABSL_FLAG(std::string, algorithm, "RISK_RRT_STAR",
          "plan: RISK_RRT_STAR, RRT, GENETIC or HARMONIC (docs/planners.md)");
ABSL_FLAG(int64_t, budget_ms, 5000, "plan: time budget, ms (0: none; then --iterations)");
ABSL_FLAG(int64_t, iterations, 0, "plan: iteration budget (0: none)");
ABSL_FLAG(uint64_t, seed, 1, "plan: planner seed");
ABSL_FLAG(std::string, planner_params, "",
          "plan: planner parameters 'name=value,...' (listed by `riskplan-server --help`)");
ABSL_FLAG(std::string, obstacles, "",
          "plan: point obstacles 'x,y;...' (or 'wgs84:lat,lon;...') kept at the planner's "
          "clearance_m (RRT, GENETIC, HARMONIC)");
ABSL_FLAG(int64_t, min_update_interval_ms, 100, "plan: least time between streamed updates, ms");
ABSL_FLAG(double, display_step_m, 25.0, "plan: spacing of the streamed display path, m");
ABSL_FLAG(bool, tree, false, "plan: draw the planner's final tree in the picture");
ABSL_FLAG(std::string, picture, "", "plan: write a picture of the plan (.svg or .png)");
ABSL_FLAG(int, picture_size, 800, "plan: largest side of the picture, pixels");
ABSL_FLAG(std::string, trajectory_out, "",
          "plan: write the best trajectory as JSON waypoints (readable by --trajectory_file); "
          "fleet: each mission's, F.json giving F-ID.json");
ABSL_FLAG(std::string, plan_out, "",
          "plan, eval: write the trajectory as a QGroundControl mission (.plan; a geo-referenced "
          "map only)");
ABSL_FLAG(std::string, geojson_out, "",
          "plan, eval: write the trajectory as GeoJSON (RFC 7946) with each sample's risk");
ABSL_FLAG(std::string, kml_out, "", "plan, eval: write the trajectory as KML");
ABSL_FLAG(double, export_spacing_m, 50.0,
          "plan, eval: spacing of the exported waypoints along the flown path, m, [1, 100000]");
ABSL_FLAG(std::string, plan_firmware, "px4",
          "plan, eval: the .plan's firmwareType: px4, ardupilot or generic");
ABSL_FLAG(double, target_level_of_safety, 1e-6,
          "plan, eval: target level of safety, expected casualties per flight hour (SORA: 1e-6); "
          "the risk per flight hour is compared with it");
ABSL_FLAG(std::string, missions, "",
          "fleet, load --rpc=fleet: the missions file, JSON (docs/api.md, \"Missions files\"); "
          "a mission's fields take the place of the plan flags of the same names");
ABSL_FLAG(int, max_resubmits, 3,
          "fleet: times the missions without a result are sent again when the stream breaks "
          "(a replica died or drained), 0 to 10");
ABSL_FLAG(std::string, rpc, "eval",
          "load: the RPC to load, eval | plan | fleet (one call: the whole --missions fleet) | "
          "ping | connect (a new connection, TLS handshake included, and one Ping on it, per "
          "call; closed loop only)");
ABSL_FLAG(std::string, mode, "closed",
          "load: closed (--concurrency callers back to back) or open (--rate calls per second, "
          "latency from the intended send time)");
ABSL_FLAG(int, concurrency, 8, "load: callers in closed loop");
ABSL_FLAG(double, rate, 100.0, "load: calls per second in open loop");
ABSL_FLAG(double, duration_s, 10.0, "load: length of the run, s");
ABSL_FLAG(int, max_outstanding, 10000,
          "load, open loop: calls in flight at most (more count as CLIENT_OVERLOADED)");
ABSL_FLAG(bool, ceiling, false,
          "load: first run Ping (a no-op RPC) with the same settings, and report the ratio");
ABSL_FLAG(std::string, report_json, "",
          "load, fleet: also write the report as JSON to this file");

namespace {

// The help: every command with the flags it reads (cmdline/help.h checks
// that each flag above is read by one at least). It is long but one table,
// kept whole so that it reads like the --help it prints: the flag groups
// first, as several commands share them, then one entry per command.
riskplan::cmdline::ProgramHelp Help() {
  riskplan::cmdline::ProgramHelp help;
  help.program = "riskplan";
  help.usage =
      "the client of riskplan-server.\n"
      "\n"
      "  riskplan --server=HOST:PORT COMMAND [flags]";
  const std::vector<std::string> trajectory = {"waypoints", "polyline", "trajectory_file"};
  const std::vector<std::string> two_tier = {"two_tier", "two_tier_rule",
                                             "two_tier_detailed_segments", "two_tier_block_cells",
                                             "two_tier_bresenham"};
  const std::vector<std::string> planning = {
      "start",          "goal",       "algorithm",
      "budget_ms",      "iterations", "seed",
      "planner_params", "obstacles",  "min_update_interval_ms",
      "display_step_m", "tree",       "wind",
      "max_flight_time_s", "max_length_m", "max_risk",
      "max_risk_per_flight_hour", "objective", "pareto"};
  const std::vector<std::string> exports = {"plan_out",      "geojson_out",
                                            "kml_out",       "export_spacing_m",
                                            "plan_firmware", "target_level_of_safety"};
  auto join = [](std::vector<std::string> a, const std::vector<std::string>& b) {
    a.insert(a.end(), b.begin(), b.end());
    return a;
  };
  const std::vector<std::string> connection = {
      "server", "tls_ca", "tls_cert", "tls_key", "tls_server_name", "token_file", "timeout_ms"};
  help.commands = {
      {"maps", "the server's maps", "  riskplan maps [--json]", join(connection, {"json"})},
      {"eval", "risk, length and admissibility of a trajectory",
       "  riskplan eval (--waypoints=... | --polyline=... | --trajectory_file=F) [flags]\n"
       "\n"
       "Prints the risk per flight hour (risk / (length / airspeed)) and whether it\n"
       "meets --target_level_of_safety. On a geo-referenced map the trajectory may be\n"
       "given in WGS84 ('wgs84:lat,lon,alt,heading_deg; ...'), and --plan_out,\n"
       "--geojson_out and --kml_out write it for ground stations and GIS\n"
       "(docs/geodata.md).\n"
       "\n"
       "Example:\n"
       "  riskplan eval --waypoints='1200,1500,250,0.785; 6800,6500,250,0.785'",
       join(join(join(connection, {"map", "json"}), trajectory),
            join(join({"samples", "params", "wind"}, two_tier), exports))},
      {"plan", "plan a trajectory, showing each improvement as it streams",
       "  riskplan plan --start=X,Y,Z,THETA --goal=X,Y,Z,THETA [flags]\n"
       "  riskplan plan --start=wgs84:LAT,LON,ALT,HEADING_DEG --goal=wgs84:... [flags]\n"
       "\n"
       "Poses are local, 'x,y,z,theta' (m east, m north, m AMSL, rad counter-clockwise\n"
       "from east), or, on a geo-referenced map (riskplan maps), WGS84 with the prefix\n"
       "'wgs84:': 'wgs84:lat,lon,alt,heading_deg' (degrees, m AMSL, degrees clockwise\n"
       "from true north); --obstacles takes 'wgs84:lat,lon; ...' too.\n"
       "\n"
       "--picture=F.svg or F.png draws the plan: population density, no-fly zones,\n"
       "landing sites, every improvement and the final trajectory, with a legend and\n"
       "a scale bar. --plan_out=F.plan (QGroundControl), --geojson_out=F.geojson and\n"
       "--kml_out=F.kml write the best trajectory sampled every --export_spacing_m, in\n"
       "WGS84 with altitudes AMSL. The risk per flight hour is compared with\n"
       "--target_level_of_safety. Exit code 3: the plan ended without a trajectory.\n"
       "If the stream breaks (the server dies, say), the error and what was received\n"
       "go to stderr, the best trajectory received is still written (--trajectory_out,\n"
       "--picture; the exports need the server) and the exit code is 1.\n"
       "\n"
       "Examples:\n"
       "  riskplan plan --start=1200,1500,250,0.785 --goal=6800,6500,250,0.785 "
       "--budget_ms=5000 --picture=plan.svg\n"
       "\n"
       "Limits: --max_flight_time_s (endurance), --max_length_m, --max_risk (per\n"
       "flight) and --max_risk_per_flight_hour (target level of safety) bound every\n"
       "trajectory streamed or returned; --objective=MIN_TIME returns the quickest\n"
       "trajectory within them; --pareto streams the risk-time front. When no\n"
       "trajectory found meets them, the plan ends NO_SOLUTION and says which limit\n"
       "and the best value found (e.g. the fastest flight time).\n"
       "\n"
       "Missions: --mission=F.plan plans a QGroundControl mission leg by leg\n"
       "(takeoff, waypoints, land or return; free headings chosen on the bisector),\n"
       "the limits shared among the legs; --mission_out=G.plan writes it planned.\n"
       "\n"
       "  riskplan plan --map=lux --start=wgs84:49.6012,6.1034,420,45 "
       "--goal=wgs84:49.6301,6.1625,430,90 --plan_out=mission.plan",
       join(join(join(connection, {"map"}), planning),
            join({"params", "picture", "picture_size", "trajectory_out", "mission", "mission_out"},
                 exports))},
      {"fleet", "plan many missions in one call (PlanFleet), with progress per mission",
       "  riskplan fleet --missions=FILE.json [plan flags] [--picture=F.svg]\n"
       "\n"
       "FILE.json: {\"missions\": [{\"id\": \"m1\", \"start\": \"x,y,z,theta\", ...}, ...],\n"
       "\"tenant\": \"...\", \"send_improvements\": true} (docs/api.md, \"Missions files\").\n"
       "A mission's keys are the plan flags' names (start, goal, map, algorithm,\n"
       "budget_ms, iterations, seed, params, wind, planner_params, obstacles,\n"
       "min_update_interval_ms, display_step_m, tree, and the limits max_flight_time_s,\n"
       "max_length_m, max_risk, max_risk_per_flight_hour, objective, pareto) plus id\n"
       "and priority; what a\n"
       "mission does not give, the flag gives (e.g. one --goal for all).\n"
       "Prints each mission's end as it comes, then a summary table; --picture draws\n"
       "every mission's trajectory on --map. Exit code 3: some mission has no\n"
       "trajectory (its own error, or NO_SOLUTION). With several replicas in\n"
       "--server, missions a broken stream left without a result are sent again\n"
       "(--max_resubmits times at most). --report_json=FILE also writes the report\n"
       "as JSON: per mission its id, replica, end, risk, length, flight time and\n"
       "re-submissions (docs/fleet.md).\n"
       "\n"
       "Example:\n"
       "  riskplan fleet --missions=fleet.json --goal=6800,6500,250,0.785 --iterations=2000 "
       "--picture=fleet.svg",
       join(join(join(connection, {"map", "missions", "max_resubmits"}), planning),
            {"params", "picture", "picture_size", "report_json", "trajectory_out"})},
      {"fly", "a scripted flight on an in-flight session (Fly): plan versions and alerts",
       "  riskplan fly --scenario=FILE.json\n"
       "\n"
       "The aircraft follows the latest plan version at its ground speed, faster than\n"
       "real time by the scenario's speedup, reporting its progress; the scenario's\n"
       "events (zones, wind, stream breaks) are sent at their flight times. Prints\n"
       "every plan version, alert and refusal. A broken stream is resumed by itself\n"
       "(on any replica of --server, --max_resubmits times at most).\n"
       "Exit code 3: the flight ended with an alert in force.\n"
       "\n"
       "Example:\n"
       "  riskplan fly --scenario=docs/examples/fly-fire.json",
       join(connection, {"scenario", "max_resubmits"})},
      {"load", "load test of one RPC (eval, plan, fleet or ping), closed or open loop",
       "  riskplan load [--rpc=eval|plan|fleet|ping] [--mode=closed|open] [flags]\n"
       "\n"
       "--rpc=eval sends the trajectory of eval's flags, --rpc=plan the plan of plan's,\n"
       "--rpc=fleet the fleet of --missions.\n"
       "\n"
       "Example:\n"
       "  riskplan load --rpc=eval --polyline='1000,1000,250;2000,1000,250' --concurrency=4 "
       "--ceiling",
       join(join(join(connection, {"map", "rpc", "missions", "mode", "concurrency", "rate",
                                   "duration_s", "max_outstanding", "ceiling", "report_json"}),
                 join(trajectory, join({"samples", "params"}, two_tier))),
            planning)},
  };
  help.footer =
      "Examples:\n"
      "  riskplan maps\n"
      "  riskplan eval --waypoints='1200,1500,250,0.785; 6800,6500,250,0.785'\n"
      "  riskplan plan --start=1200,1500,250,0.785 --goal=6800,6500,250,0.785 "
      "--budget_ms=5000 --picture=plan.svg\n"
      "\n"
      "Exit codes: 0 success; 1 the RPC failed, or a flag is unknown or malformed;\n"
      "2 bad input; 3 plan found no trajectory.\n"
      "Units: metres, metres above mean sea level, radians counter-clockwise from east;\n"
      "with 'wgs84:', degrees of latitude and longitude and degrees clockwise from north.";
  return help;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string command = riskplan::cmdline::ParseCommand(argc, argv, Help());

  riskplan::client::CliOptions o;
  o.server = absl::GetFlag(FLAGS_server);
  o.connection = riskplan::client::ConnectionOptionsFromFlags();
  o.map = absl::GetFlag(FLAGS_map);
  o.timeout = absl::Milliseconds(absl::GetFlag(FLAGS_timeout_ms));
  o.json = absl::GetFlag(FLAGS_json);
  o.waypoints = absl::GetFlag(FLAGS_waypoints);
  o.polyline = absl::GetFlag(FLAGS_polyline);
  o.trajectory_file = absl::GetFlag(FLAGS_trajectory_file);
  o.samples = absl::GetFlag(FLAGS_samples);
  o.two_tier = absl::GetFlag(FLAGS_two_tier);
  o.two_tier_rule = absl::GetFlag(FLAGS_two_tier_rule);
  o.two_tier_detailed_segments = absl::GetFlag(FLAGS_two_tier_detailed_segments);
  o.two_tier_block_cells = absl::GetFlag(FLAGS_two_tier_block_cells);
  o.two_tier_bresenham = absl::GetFlag(FLAGS_two_tier_bresenham);
  o.params = absl::GetFlag(FLAGS_params);
  o.wind = absl::GetFlag(FLAGS_wind);
  o.start = absl::GetFlag(FLAGS_start);
  o.goal = absl::GetFlag(FLAGS_goal);
  o.algorithm = absl::GetFlag(FLAGS_algorithm);
  o.budget_ms = absl::GetFlag(FLAGS_budget_ms);
  o.iterations = absl::GetFlag(FLAGS_iterations);
  o.seed = absl::GetFlag(FLAGS_seed);
  o.planner_params = absl::GetFlag(FLAGS_planner_params);
  o.obstacles = absl::GetFlag(FLAGS_obstacles);
  o.min_update_interval_ms = absl::GetFlag(FLAGS_min_update_interval_ms);
  o.display_step_m = absl::GetFlag(FLAGS_display_step_m);
  o.tree = absl::GetFlag(FLAGS_tree);
  o.max_flight_time_s = absl::GetFlag(FLAGS_max_flight_time_s);
  o.max_length_m = absl::GetFlag(FLAGS_max_length_m);
  o.max_risk = absl::GetFlag(FLAGS_max_risk);
  o.max_risk_per_flight_hour = absl::GetFlag(FLAGS_max_risk_per_flight_hour);
  o.objective = absl::GetFlag(FLAGS_objective);
  o.pareto = absl::GetFlag(FLAGS_pareto);
  o.mission = absl::GetFlag(FLAGS_mission);
  o.mission_out = absl::GetFlag(FLAGS_mission_out);
  o.picture = absl::GetFlag(FLAGS_picture);
  o.picture_size = absl::GetFlag(FLAGS_picture_size);
  o.trajectory_out = absl::GetFlag(FLAGS_trajectory_out);
  o.exports.plan_out = absl::GetFlag(FLAGS_plan_out);
  o.exports.geojson_out = absl::GetFlag(FLAGS_geojson_out);
  o.exports.kml_out = absl::GetFlag(FLAGS_kml_out);
  o.exports.spacing_m = absl::GetFlag(FLAGS_export_spacing_m);
  o.plan_firmware = absl::GetFlag(FLAGS_plan_firmware);
  o.target_level_of_safety = absl::GetFlag(FLAGS_target_level_of_safety);
  o.missions = absl::GetFlag(FLAGS_missions);
  o.scenario = absl::GetFlag(FLAGS_scenario);
  o.max_resubmits = absl::GetFlag(FLAGS_max_resubmits);
  o.rpc = absl::GetFlag(FLAGS_rpc);
  o.mode = absl::GetFlag(FLAGS_mode);
  o.concurrency = absl::GetFlag(FLAGS_concurrency);
  o.rate = absl::GetFlag(FLAGS_rate);
  o.duration_s = absl::GetFlag(FLAGS_duration_s);
  o.max_outstanding = absl::GetFlag(FLAGS_max_outstanding);
  o.ceiling = absl::GetFlag(FLAGS_ceiling);
  o.report_json = absl::GetFlag(FLAGS_report_json);

  // Creating the channel does not connect (gRPC connects on the first call),
  // so it costs nothing before the command is known to be valid; a bad
  // --server shows up as UNAVAILABLE from the first call. It reads the TLS
  // and token files, though: one that cannot be read is bad input.
  absl::StatusOr<std::shared_ptr<grpc::Channel>> channel =
      riskplan::client::MakeChannel(o.server, o.connection);
  if (!channel.ok()) {
    std::fprintf(stderr, "riskplan: %s\n", std::string(channel.status().message()).c_str());
    return 2;
  }
  riskplan::client::RiskplanClient client(*std::move(channel));
  if (command == "maps") return riskplan::client::RunMaps(o, client);
  if (command == "eval") return riskplan::client::RunEval(o, client);
  if (command == "plan") return riskplan::client::RunPlan(o, client);
  if (command == "fleet") return riskplan::client::RunFleet(o, client);
  if (command == "fly") return riskplan::client::RunFly(o, client);
  return riskplan::client::RunLoad(o, client);  // ParseCommand allows no other
}
