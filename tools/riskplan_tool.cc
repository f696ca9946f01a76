// riskplan-tool: offline access to riskplan's core (no server needed), and
// map bundles from real geodata (import). Its commands, their synopses and
// flags are in Help() below (`riskplan-tool --help`, `riskplan-tool COMMAND
// --help`).
#include <cmath>
#include <csignal>
#include <cstdio>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "cmdline/help.h"
#include "core/flight/trajectory.h"
#include "core/flight/trajectory_io.h"
#include "core/map/demo_city.h"
#include "core/map/map_bundle.h"
#include "core/risk/risk_layer.h"
#include "core/risk/risk_model.h"
#include "geo/geo_frame.h"
#include "geo/risk_layer_geotiff.h"
#include "nlohmann/json.hpp"
#include "tools/import_command.h"
#include "tools/layer_writers.h"

ABSL_FLAG(std::string, map, "",
          "Map bundle directory (docs/map-bundle.md). Empty: the built-in demo-city.");
ABSL_FLAG(std::string, waypoints, "",
          "evaluate: waypoints 'x,y,z,theta;...' (m, m, m AMSL, rad), joined by Dubins-airplane "
          "manoeuvres");
ABSL_FLAG(std::string, polyline, "", "evaluate: polyline 'x,y,z;...' of straight segments");
ABSL_FLAG(std::string, trajectory_file, "",
          "evaluate: JSON file {\"waypoints\": [[x,y,z,theta],...]} or {\"polyline\": "
          "[[x,y,z],...]}");
ABSL_FLAG(bool, samples, false, "evaluate: also print every sample's configuration risk");
ABSL_FLAG(bool, json, false, "evaluate: print the result as JSON");
ABSL_FLAG(std::string, params, "",
          "Model parameter overrides 'name=value,...' (names as in docs/risk-model.md, e.g. "
          "mass_kg=12,airspeed_mps=20)");
ABSL_FLAG(std::string, wind, "",
          "evaluate, risk-layer: the mean wind SPEED@FROM_DEG, m/s and the direction it blows "
          "from in degrees clockwise from the map's grid north (any finite value, taken modulo "
          "360; at most half the airspeed), e.g. 8@270; the same as --params="
          "wind_speed_mps=8,wind_from_deg=270. Empty: still air");
ABSL_FLAG(std::string, out, "",
          "the bundle's directory (write-map, import), or the output files' prefix (risk-layer)");
ABSL_FLAG(uint64_t, seed, riskplan::kDemoCitySeed, "write-map: demo-city seed");
ABSL_FLAG(double, size_m, 8000.0, "write-map, import: the map's side in metres");
ABSL_FLAG(double, res_m, 5.0, "write-map, import: the cell size in metres");
ABSL_FLAG(double, agl_m, 100.0, "risk-layer: height above the terrain of every cell, m");
ABSL_FLAG(std::string, heading_deg, "0",
          "risk-layer: heading in degrees counter-clockwise from east, or 'max' for the maximum "
          "over all heading bins");
ABSL_FLAG(int, threads, 1, "risk-layer, import: worker threads");
ABSL_FLAG(int, stride, 1,
          "risk-layer: layer cell side in map cells; each value is M at the centre of its "
          "stride x stride block, and a partial block at the east or north edge is left out");

namespace riskplan {
namespace {

// The help: every command with the flags it reads (cmdline/help.h checks
// that each flag above is read by one at least).
cmdline::ProgramHelp Help() {
  cmdline::ProgramHelp help;
  help.program = "riskplan-tool";
  help.usage =
      "offline risk evaluation and map tools (no server needed).\n"
      "\n"
      "  riskplan-tool COMMAND [flags]";
  help.commands = {
      {"evaluate",
       "risk, length and admissibility of a trajectory on a map",
       "  riskplan-tool evaluate [--map=DIR] (--waypoints=... | --polyline=... |\n"
       "                         --trajectory_file=F) [--samples] [--json] [--params=...]\n"
       "\n"
       "Examples:\n"
       "  riskplan-tool evaluate --waypoints='1000,1000,250,0; 7000,7000,250,1.57'\n"
       "  riskplan-tool evaluate --map=maps/demo-city --polyline='0,0,200;100,0,200' --samples",
       {"map", "waypoints", "polyline", "trajectory_file", "samples", "json", "params", "wind"}},
      {"write-map",
       "write the built-in demo-city as a map bundle (--out=DIR)",
       "  riskplan-tool write-map --out=DIR [--seed=N] [--size_m=M] [--res_m=R]\n"
       "\n"
       "DIR appears complete or not at all: the bundle is written beside it, flushed\n"
       "to disk, then renamed into place, replacing a map bundle (or an empty\n"
       "directory) at DIR in one step; anything else there is left alone\n"
       "(docs/map-bundle.md, \"Writing a bundle\").\n"
       "\n"
       "Example:\n"
       "  riskplan-tool write-map --out=maps/demo-city",
       {"out", "seed", "size_m", "res_m", "params"}},
      {"info", "describe a map", "  riskplan-tool info [--map=DIR]", {"map", "params"}},
      {"risk-layer",
       "configuration risk of every cell at a height above ground",
       "  riskplan-tool risk-layer [--map=DIR] --out=PREFIX [--agl_m=100] [--heading_deg=0|max]\n"
       "                           [--threads=N] [--stride=1] [--wind=SPEED@FROM_DEG]\n"
       "\n"
       "In wind (risk model version 3) the risk depends on the direction flown:\n"
       "--heading_deg is the track over the ground (the aircraft points at its air\n"
       "heading), and 'max' the worst track heading bin.\n"
       "\n"
       "Writes a PNG heat map (PREFIX.png), an ESRI ASCII grid (PREFIX.asc), plus its\n"
       "projection (PREFIX.prj) when the map has a geo-reference, and a Cloud-Optimized\n"
       "GeoTIFF (PREFIX.tif: Float64 M, NODATA NaN where undefined, and the map's local\n"
       "frame as its CRS when the map has a geo-reference).\n"
       "\n"
       "Example:\n"
       "  riskplan-tool risk-layer --out=out/risk-100m --agl_m=100 --heading_deg=max --threads=2",
       {"map", "out", "agl_m", "heading_deg", "threads", "stride", "params", "wind"}},
      ImportCommandHelp(),
  };
  help.footer = "Exit codes: 0 success; 1 failure, or a flag unknown or malformed; 2 bad input.";
  return help;
}

// The exit codes of the help's footer: 2 for bad input (InvalidArgument), 1
// for any other failure.
int Fail(const absl::Status& status) {
  std::fprintf(stderr, "riskplan-tool: %s\n", std::string(status.message()).c_str());
  return status.code() == absl::StatusCode::kInvalidArgument ? 2 : 1;
}

// --wind=SPEED@FROM_DEG onto `params` (nothing when empty); refused beside
// --params' own wind fields.
absl::Status WindFromFlag(ModelParams* params) {
  const std::string text = absl::GetFlag(FLAGS_wind);
  if (text.empty()) return absl::OkStatus();
  const auto bad = [&](const std::string& why) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "--wind='%s' is not SPEED@FROM_DEG (m/s @ degrees clockwise from the map's grid north "
        "the wind blows from, e.g. 8@270 for a west wind of 8 m/s): %s",
        text, why));
  };
  const std::vector<std::string> parts = absl::StrSplit(text, '@');
  if (parts.size() != 2) return bad("it needs one '@' between the speed and the direction");
  double speed = 0.0;
  double from = 0.0;
  if (!absl::SimpleAtod(parts[0], &speed) || !std::isfinite(speed)) {
    return bad(absl::StrFormat("the speed '%s' is not a finite number", parts[0]));
  }
  if (speed < 0.0) return bad(absl::StrFormat("the speed %g is negative", speed));
  if (!absl::SimpleAtod(parts[1], &from) || !std::isfinite(from)) {
    return bad(absl::StrFormat("the direction '%s' is not a finite number", parts[1]));
  }
  const std::string given = absl::GetFlag(FLAGS_params);
  if (given.find("wind_speed_mps") != std::string::npos ||
      given.find("wind_from_deg") != std::string::npos) {
    return absl::InvalidArgumentError(
        "--wind and --params' wind_speed_mps / wind_from_deg both give the wind; give it once");
  }
  if (speed > kMaxWindFraction * params->airspeed_mps) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "--wind: the speed %g m/s is more than %g times the airspeed (%g m/s), i.e. %g m/s",
        speed, kMaxWindFraction, params->airspeed_mps, kMaxWindFraction * params->airspeed_mps));
  }
  params->wind_speed_mps = speed;
  params->wind_from_deg = from;
  return absl::OkStatus();
}

absl::StatusOr<ModelParams> ParamsFromFlag() {
  ModelParams params;
  const std::string text = absl::GetFlag(FLAGS_params);
  for (absl::string_view item : absl::StrSplit(text, ',', absl::SkipWhitespace())) {
    std::vector<std::string> kv = absl::StrSplit(item, absl::MaxSplits('=', 1));
    double value = 0.0;
    if (kv.size() != 2 || !absl::SimpleAtod(kv[1], &value)) {
      return absl::InvalidArgumentError(
          absl::StrFormat("--params: '%s' is not name=number", std::string(item)));
    }
    if (absl::Status s =
            SetModelParam(&params, std::string(absl::StripAsciiWhitespace(kv[0])), value);
        !s.ok()) {
      return absl::InvalidArgumentError(absl::StrFormat("--params: %s", s.message()));
    }
  }
  if (absl::Status s = WindFromFlag(&params); !s.ok()) return s;
  if (absl::Status s = ValidateModelParams(params); !s.ok()) return s;
  return params;
}

absl::StatusOr<std::shared_ptr<const RiskMap>> LoadMap(const ModelParams& params) {
  const std::string dir = absl::GetFlag(FLAGS_map);
  if (dir.empty()) return MakeDemoCity(DemoCityOptions{}, params);
  return LoadMapBundle(dir, params);
}

absl::StatusOr<TrajectoryInput> TrajectoryFromFlags() {
  const std::string w = absl::GetFlag(FLAGS_waypoints);
  const std::string p = absl::GetFlag(FLAGS_polyline);
  const std::string f = absl::GetFlag(FLAGS_trajectory_file);
  const int given = !w.empty() + !p.empty() + !f.empty();
  if (given != 1) {
    return absl::InvalidArgumentError(
        "evaluate: give exactly one of --waypoints, --polyline and --trajectory_file");
  }
  TrajectoryInput input;
  if (!f.empty()) return ReadTrajectoryFile(f);
  if (!w.empty()) {
    auto parsed = ParseWaypoints(w);
    if (!parsed.ok()) return parsed.status();
    input.waypoints = *std::move(parsed);
  } else {
    auto parsed = ParsePolyline(p);
    if (!parsed.ok()) return parsed.status();
    input.polyline = *std::move(parsed);
  }
  return input;
}

void PrintText(const RiskMap& map, const ModelParams& params, const TrajectoryInput& input,
               const TrajectoryEvaluation& e, bool samples) {
  std::printf("map         %s (%d x %d cells of %g m, origin (%g, %g))\n", map.name().c_str(),
              map.nx(), map.ny(), map.res(), map.x0(), map.y0());
  if (input.is_polyline()) {
    std::printf("trajectory  polyline of %zu points, %zu straight pieces\n", input.polyline.size(),
                e.pieces.size());
  } else {
    std::printf("trajectory  %zu waypoints, %zu Dubins-airplane pieces\n", input.waypoints.size(),
                e.pieces.size());
  }
  std::printf("risk        %.6e expected casualties per flight\n", e.risk);
  std::printf("length      %.1f m\n", e.length_m);
  if (!params.Calm()) {
    // Still air prints what it always did; in wind the time is the sum of
    // ds / ground speed (spec version 3, section 4).
    std::printf("wind        %g m/s from %g deg (grid north)\n", params.wind_speed_mps,
                params.wind_from_deg);
    std::printf("flight time %.2f s (%.2f s in still air)\n", e.flight_time_s,
                e.length_m / params.airspeed_mps);
  }
  std::printf("admissible  %s\n", e.admissible ? "yes" : "no");
  if (e.first_violation.has_value()) {
    std::printf("violation   %s\n", e.first_violation->ToString().c_str());
  }
  for (size_t p = 0; p < e.pieces.size(); ++p) {
    std::printf("  piece %zu: length %.1f m, %lld samples, risk %.6e%s\n", p, e.pieces[p].length_m,
                static_cast<long long>(e.pieces[p].parts), e.pieces[p].risk,
                e.pieces[p].admissible ? "" : ", inadmissible");
  }
  if (samples) {
    std::printf("%5s %10s %10s %10s %8s %8s %14s %12s %8s %8s\n", "piece", "s_m", "x_m", "y_m",
                "z_m", "theta", "M", "I", "S", "p_cas");
    for (const SampleEvaluation& s : e.samples) {
      std::printf("%5d %10.3f %10.3f %10.3f %8.3f %8.5f %14.8e %12.6e %8.5f %8.6f\n", s.piece,
                  s.arc_length_m, s.pose.x, s.pose.y, s.pose.z, s.pose.theta, s.risk.risk,
                  s.risk.impact_factor, s.risk.expected_shelter, s.risk.casualty_probability);
    }
  }
}

void PrintJson(const RiskMap& map, const ModelParams& params, const TrajectoryEvaluation& e,
               bool samples) {
  nlohmann::json out;
  out["map"] = map.name();
  out["risk"] = e.risk;
  out["length_m"] = e.length_m;
  if (!params.Calm()) {
    out["flight_time_s"] = e.flight_time_s;
    out["wind_speed_mps"] = params.wind_speed_mps;
    out["wind_from_deg"] = params.wind_from_deg;
  }
  out["admissible"] = e.admissible;
  if (e.first_violation.has_value()) {
    const Violation& v = *e.first_violation;
    out["first_violation"] = {{"kind", std::string(ViolationKindName(v.kind))},
                              {"x", v.pose.x},
                              {"y", v.pose.y},
                              {"z", v.pose.z},
                              {"arc_length_m", v.arc_length_m},
                              {"piece", v.piece},
                              {"message", v.ToString()}};
  }
  for (const PieceEvaluation& p : e.pieces) {
    out["pieces"].push_back({{"risk", p.risk},
                             {"length_m", p.length_m},
                             {"samples", p.parts},
                             {"admissible", p.admissible}});
  }
  if (samples) {
    out["samples"] = nlohmann::json::array();
    for (const SampleEvaluation& s : e.samples) {
      out["samples"].push_back({{"piece", s.piece},
                                {"arc_length_m", s.arc_length_m},
                                {"x", s.pose.x},
                                {"y", s.pose.y},
                                {"z", s.pose.z},
                                {"theta", s.pose.theta},
                                {"M", s.risk.risk},
                                {"I", s.risk.impact_factor},
                                {"S", s.risk.expected_shelter},
                                {"p_cas", s.risk.casualty_probability},
                                {"defined", s.risk.defined}});
    }
  }
  std::printf("%s\n", out.dump(2).c_str());
}

int Evaluate() {
  auto params = ParamsFromFlag();
  if (!params.ok()) return Fail(params.status());
  auto input = TrajectoryFromFlags();
  if (!input.ok()) return Fail(input.status());
  auto map = LoadMap(*params);
  if (!map.ok()) return Fail(map.status());
  auto model = RiskModel::Create(*map, *params);
  if (!model.ok()) return Fail(model.status());
  auto pieces = input->is_polyline() ? PiecesFromPolyline(input->polyline)
                                     : PiecesFromWaypoints(input->waypoints, *params);
  if (!pieces.ok()) return Fail(pieces.status());
  const bool samples = absl::GetFlag(FLAGS_samples);
  auto eval = EvaluateTrajectory(**model, *pieces, {.keep_samples = samples});
  if (!eval.ok()) return Fail(eval.status());
  if (absl::GetFlag(FLAGS_json)) {
    PrintJson(**map, *params, *eval, samples);
  } else {
    PrintText(**map, *params, *input, *eval, samples);
  }
  return 0;
}

int WriteMap() {
  const std::string out = absl::GetFlag(FLAGS_out);
  if (out.empty()) return Fail(absl::InvalidArgumentError("write-map: --out=DIR is required"));
  auto params = ParamsFromFlag();
  if (!params.ok()) return Fail(params.status());
  const absl::Time start = absl::Now();
  auto map = MakeDemoCity(DemoCityOptions{absl::GetFlag(FLAGS_seed), absl::GetFlag(FLAGS_size_m),
                                          absl::GetFlag(FLAGS_res_m)},
                          *params);
  if (!map.ok()) return Fail(map.status());
  const double generate_s = absl::ToDoubleSeconds(absl::Now() - start);
  // As import does: a bundle at --out is replaced, anything else refused.
  if (absl::Status s = WriteMapBundleAtomically(**map, out, ExistingDirectory::kReplace); !s.ok()) {
    return Fail(s);
  }
  std::printf("wrote %s (%d x %d cells, generated in %.2f s) to %s\n", (*map)->name().c_str(),
              (*map)->nx(), (*map)->ny(), generate_s, out.c_str());
  return 0;
}

int Info() {
  auto params = ParamsFromFlag();
  if (!params.ok()) return Fail(params.status());
  auto map = LoadMap(*params);
  if (!map.ok()) return Fail(map.status());
  const RiskMap& m = **map;
  std::printf("name            %s\n", m.name().c_str());
  std::printf("origin          (%g, %g) m\n", m.x0(), m.y0());
  std::printf("size            %d x %d cells of %g m (%g x %g m)\n", m.nx(), m.ny(), m.res(),
              m.width_m(), m.height_m());
  std::printf("landing sites   %zu\n", m.landing_sites().size());
  std::printf("provenance      %s\n", m.header().provenance.c_str());
  std::printf("memory          %.1f MiB\n", m.MemoryBytes() / 1048576.0);
  // Spec version 2: where a fall's impact window reaches past the map, the
  // risk is undefined and flight is not admissible. The flyable area is the
  // map minus this reach at each height.
  auto model = RiskModel::Create(*map, *params);
  if (!model.ok()) return Fail(model.status());
  const double total = static_cast<double>(m.nx()) * m.ny();
  for (auto [agl, which] :
       {std::pair{params->min_agl_m, "min_agl"}, {params->max_agl_m, "max_agl"}}) {
    const ImpactReach r = (*model)->Reach(agl);
    std::printf(
        "impact reach    at %g m AGL (%s, height bin %d): %.1f m (west %.1f, east %.1f, south "
        "%.1f, north %.1f m); window inside the map for every heading on %.1f %% of the map\n",
        agl, which, r.height_bin, r.Max(), r.west_m, r.east_m, r.south_m, r.north_m,
        100.0 * static_cast<double>(r.CellsClear(m)) / total);
  }
  return 0;
}

// risk-layer's options from --agl_m, --threads, --stride and --heading_deg
// (its text is passed in: the outputs describe it too).
absl::StatusOr<RiskLayerOptions> RiskLayerOptionsFromFlags(const std::string& heading) {
  RiskLayerOptions options;
  options.height_agl_m = absl::GetFlag(FLAGS_agl_m);
  options.threads = absl::GetFlag(FLAGS_threads);
  options.stride = absl::GetFlag(FLAGS_stride);
  double degrees = 0.0;
  if (heading == "max") {
    options.heading_rad = std::nan("");
  } else if (absl::SimpleAtod(heading, &degrees) && std::isfinite(degrees)) {
    options.heading_rad = NormalizeHeading(degrees * kPi / 180.0);
  } else {
    return absl::InvalidArgumentError(absl::StrFormat(
        "risk-layer: --heading_deg='%s' is neither a number of degrees nor 'max'", heading));
  }
  return options;
}

// Where a risk layer sits on the Earth: the .prj's WKT and the GeoTIFF's
// frame, both empty when the map has no geo-reference.
struct LayerPlacement {
  std::string wkt;
  std::optional<geo::GeoFrame> frame;
};

absl::StatusOr<LayerPlacement> PlacementOf(const RiskMap& map) {
  LayerPlacement placement;
  const std::optional<GeoReference>& geo = map.header().geo;
  if (!geo.has_value()) return placement;
  auto text = LocalAzimuthalEquidistantWkt(*geo, map.name(), map.x0(), map.y0());
  if (!text.ok()) return text.status();
  placement.wkt = *std::move(text);
  auto frame = geo::FrameOfMap(map.header());
  if (!frame.ok()) return frame.status();
  placement.frame = *std::move(frame);
  return placement;
}

// Writes PREFIX.png, .asc, .tif and, with a geo-reference, .prj. Returns
// whether a stale .prj was removed.
absl::StatusOr<bool> WriteLayerFiles(const RiskLayer& layer, const RiskMap& map,
                                     const LayerPlacement& placement,
                                     const RiskLayerOptions& options, const std::string& heading,
                                     const std::string& wind, const std::string& out) {
  if (absl::Status s = WriteHeatMapPng(layer, out + ".png"); !s.ok()) return s;
  if (absl::Status s = WriteAsciiGrid(layer, out + ".asc"); !s.ok()) return s;
  if (absl::Status s = geo::WriteRiskLayerGeoTiff(
          layer, placement.frame.has_value() ? &*placement.frame : nullptr,
          {map.name(), options.height_agl_m,
           (heading == "max" ? "max over heading bins"
                             : heading + " deg counter-clockwise from east") +
               wind},
          out + ".tif");
      !s.ok()) {
    return s;
  }
  const std::string prj = out + ".prj";
  if (map.header().geo.has_value()) {
    if (absl::Status s = WriteTextFile(placement.wkt, prj); !s.ok()) return s;
    return false;
  }
  // A .prj left by an earlier run would place this .asc wrongly in a GIS.
  return std::remove(prj.c_str()) == 0;
}

void PrintLayerReport(const RiskLayer& layer, const RiskMap& map, const RiskLayerOptions& options,
                      const std::string& heading, const std::string& out, double seconds,
                      bool removed_stale_prj) {
  const std::optional<GeoReference>& geo = map.header().geo;
  const std::string prj = out + ".prj";
  const int64_t cells = static_cast<int64_t>(layer.nx) * layer.ny;
  std::printf("risk layer of %s: %d x %d cells of %g m at %.0f m AGL, heading %s\n",
              map.name().c_str(), layer.nx, layer.ny, layer.res_m, options.height_agl_m,
              heading == "max" ? "max over bins" : (heading + " deg").c_str());
  if (layer.nx * options.stride != map.nx() || layer.ny * options.stride != map.ny()) {
    std::printf("stride %d leaves out the last %d column(s) and %d row(s) of the map\n",
                options.stride, map.nx() - layer.nx * options.stride,
                map.ny() - layer.ny * options.stride);
  }
  std::printf(
      "computed %lld configuration risks in %.3f s on %d thread(s): %.0f cells/s, "
      "%.0f risks/s per thread\n",
      static_cast<long long>(layer.evaluations), seconds, options.threads, cells / seconds,
      layer.evaluations / seconds / options.threads);
  if (geo.has_value()) {
    std::printf(
        "wrote %s.png, %s.asc and %s (azimuthal equidistant on WGS84 centred at "
        "%.9g, %.9g deg = map point (%g, %g) m; map crs '%s')\n",
        out.c_str(), out.c_str(), prj.c_str(), geo->origin_lat_deg, geo->origin_lon_deg,
        map.x0(), map.y0(), geo->crs.c_str());
  } else {
    std::printf(
        "wrote %s.png and %s.asc; no .prj: the map has no geo-reference, so the grid is "
        "in the map's local metres only%s\n",
        out.c_str(), out.c_str(),
        removed_stale_prj ? (" (removed a stale " + prj + ")").c_str() : "");
  }
  std::printf("wrote %s.tif (Cloud-Optimized GeoTIFF, Float64, NODATA NaN%s)\n", out.c_str(),
              geo.has_value() ? ", CRS the map's local frame" : ", no CRS");
}

int RiskLayerCommand() {
  const std::string out = absl::GetFlag(FLAGS_out);
  if (out.empty()) return Fail(absl::InvalidArgumentError("risk-layer: --out=PREFIX is required"));
  auto params = ParamsFromFlag();
  if (!params.ok()) return Fail(params.status());
  const std::string heading = absl::GetFlag(FLAGS_heading_deg);
  auto options = RiskLayerOptionsFromFlags(heading);
  if (!options.ok()) return Fail(options.status());
  auto map = LoadMap(*params);
  if (!map.ok()) return Fail(map.status());
  auto model = RiskModel::Create(*map, *params);
  if (!model.ok()) return Fail(model.status());
  // The .prj is checked before the long computation, so a bad geo-reference
  // costs nothing.
  auto placement = PlacementOf(**map);
  if (!placement.ok()) return Fail(placement.status());
  const absl::Time start = absl::Now();
  auto layer = ComputeRiskLayer(**model, *options);
  if (!layer.ok()) return Fail(layer.status());
  const double seconds = absl::ToDoubleSeconds(absl::Now() - start);
  // In wind the GeoTIFF's heading says which wind (still air: as before).
  const std::string wind =
      params->Calm() ? ""
                     : absl::StrFormat(" (track), wind %g m/s from %g deg", params->wind_speed_mps,
                                       params->wind_from_deg);
  auto removed_stale_prj =
      WriteLayerFiles(*layer, **map, *placement, *options, heading, wind, out);
  if (!removed_stale_prj.ok()) return Fail(removed_stale_prj.status());
  PrintLayerReport(*layer, **map, *options, heading, out, seconds, *removed_stale_prj);
  if (!params->Calm()) {
    const double from = std::fmod(std::fmod(params->wind_from_deg, 360.0) + 360.0, 360.0);
    std::printf("in a wind of %g m/s from %.1f deg (clockwise from grid north)%s\n",
                params->wind_speed_mps, from,
                heading == "max" ? ": the worst track heading bin of each cell"
                                 : ": the heading is the track over the ground");
  }
  return 0;
}

}  // namespace
}  // namespace riskplan

int main(int argc, char** argv) {
  // A file size limit (ulimit -f) fails a write with EFBIG, which is reported
  // and cleaned up, instead of killing the process mid-bundle (write-map,
  // import) or mid-raster (risk-layer).
  std::signal(SIGXFSZ, SIG_IGN);
  const std::string command = riskplan::cmdline::ParseCommand(argc, argv, riskplan::Help());
  if (command == "evaluate") return riskplan::Evaluate();
  if (command == "write-map") return riskplan::WriteMap();
  if (command == "info") return riskplan::Info();
  if (command == "import") return riskplan::ImportCommand(argc, argv);
  return riskplan::RiskLayerCommand();  // ParseCommand allows no other
}
