// riskplan-bench-wind: planning in a mean wind (risk model version 3) on
// demo-city, in three parts (docs/benchmarks.md, "Wind"):
//
//  rate   RISK_RRT_STAR's tree nodes per CPU second of its thread in still air
//         and in two 8 m/s winds (from the west, from the north), the runs of
//         the three airs interleaved (scenario, seed, air), medians and ratios;
//  build  what the first plan in a new wind pays for its model: the model
//         (RiskModel::Create given the default table) and its two parts,
//         ImpactTable::InWind and the directional glide layer, CPU seconds of
//         this thread, medians over distinct winds;
//  blind  the README's demo (scripts/run-demo.sh's start and goal) and three
//         of the OMPL scenarios: the still-air plan evaluated in each wind
//         and the wind's plan evaluated in still air (RISK_RRT_STAR, an
//         iteration budget: the figures repeat bit for bit).
//
//   riskplan-bench-wind [--parts=rate,build,blind] [--seeds=3] [--budget_s=2]
//                       [--rate_scenarios=...] [--winds=8] [--blind_iterations=3000]
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/strings/str_split.h"
#include "bench/planner_runs.h"
#include "cmdline/help.h"
#include "core/base/wind.h"
#include "core/flight/trajectory.h"
#include "core/map/demo_city.h"
#include "core/planners/planner.h"
#include "core/risk/impact_table.h"
#include "core/risk/risk_model.h"

ABSL_FLAG(std::string, parts, "rate,build,blind", "comma-separated parts to run");
ABSL_FLAG(int, seeds, 3, "rate: seeds per scenario and air");
ABSL_FLAG(double, budget_s, 2.0, "rate: wall-time budget per run, s");
ABSL_FLAG(std::string, rate_scenarios, "west-east,south-north,sw-ne,5km-a,suburb-w,edge-2",
          "rate: comma-separated demo-city scenarios");
ABSL_FLAG(int, winds, 8, "build: distinct new winds timed");
ABSL_FLAG(int64_t, blind_iterations, 3000, "blind: RISK_RRT_STAR iterations per plan");
ABSL_FLAG(std::string, blind_scenarios, "west-east,south-north,5km-a",
          "blind: demo-city scenarios besides the README's demo");

namespace riskplan {
namespace {

using bench::Median;
using bench::ThreadCpuSeconds;

struct Air {
  const char* name;
  double speed_mps;
  double from_deg;
};
constexpr Air kAirs[] = {{"still", 0.0, 0.0}, {"W8 from west", 8.0, 270.0},
                         {"W8 from north", 8.0, 0.0}};

std::shared_ptr<const RiskModel> ModelIn(const std::shared_ptr<const RiskModel>& calm,
                                         const Air& air) {
  if (air.speed_mps == 0.0) return calm;
  ModelParams p = calm->params();
  p.wind_speed_mps = air.speed_mps;
  p.wind_from_deg = air.from_deg;
  auto model = RiskModel::Create(calm->map_ptr(), p, calm->table_ptr());
  if (!model.ok()) {
    std::fprintf(stderr, "%s\n", std::string(model.status().message()).c_str());
    std::exit(1);
  }
  return *model;
}

bool Wanted(const std::string& parts, const char* part) {
  for (absl::string_view p : absl::StrSplit(parts, ',')) {
    if (p == part) return true;
  }
  return false;
}

const bench::Scenario* Find(const std::vector<bench::Scenario>& all, absl::string_view name) {
  for (const bench::Scenario& s : all) {
    if (name == s.name) return &s;
  }
  std::fprintf(stderr, "no scenario '%s'\n", std::string(name).c_str());
  std::exit(1);
}

void Rate(const std::shared_ptr<const RiskModel>& calm,
          const std::vector<bench::Scenario>& all) {
  std::vector<std::shared_ptr<const RiskModel>> models;
  for (const Air& air : kAirs) models.push_back(ModelIn(calm, air));
  const int seeds = absl::GetFlag(FLAGS_seeds);
  const double budget = absl::GetFlag(FLAGS_budget_s);
  std::vector<const bench::Scenario*> scenarios;
  for (absl::string_view name : absl::StrSplit(absl::GetFlag(FLAGS_rate_scenarios), ',')) {
    scenarios.push_back(Find(all, name));
  }
  std::printf("rate: RISK_RRT_STAR, %zu scenarios x %d seeds x %zu airs (interleaved), %.1f s "
              "each; nodes per CPU second of the planner's thread (configurations per node)\n",
              scenarios.size(), seeds, std::size(kAirs), budget);
  std::printf("%-14s", "scenario");
  for (const Air& air : kAirs) std::printf(" %15s", air.name);
  std::printf("\n");
  std::vector<std::vector<double>> all_rates(std::size(kAirs));
  std::vector<std::vector<double>> all_ratios(std::size(kAirs));
  std::vector<std::vector<double>> all_per_node(std::size(kAirs));
  std::vector<std::vector<double>> all_configs(std::size(kAirs));
  for (const bench::Scenario* sc : scenarios) {
    std::vector<std::vector<double>> rates(std::size(kAirs));
    std::vector<std::vector<double>> per_node(std::size(kAirs));
    for (int seed = 1; seed <= seeds; ++seed) {
      std::vector<double> run(std::size(kAirs));
      for (size_t a = 0; a < std::size(kAirs); ++a) {
        auto planner = MakePlanner(PlannerAlgorithm::kRiskRrtStar);
        PlanOptions options;
        options.budget.max_time_s = budget;
        options.seed = seed;
        CancellationToken cancel;
        const double cpu_before = ThreadCpuSeconds();
        auto result =
            (*planner)->Plan({models[a], sc->start, sc->goal}, options, cancel, nullptr);
        const double cpu_s = ThreadCpuSeconds() - cpu_before;
        if (!result.ok()) {
          std::fprintf(stderr, "%s: %s\n", sc->name,
                       std::string(result.status().message()).c_str());
          std::exit(1);
        }
        run[a] = result->tree_size / cpu_s;
        rates[a].push_back(run[a]);
        all_rates[a].push_back(run[a]);
        const double configs = static_cast<double>(result->configurations_evaluated);
        per_node[a].push_back(configs / result->tree_size);
        all_per_node[a].push_back(configs / result->tree_size);
        all_configs[a].push_back(configs / cpu_s);
      }
      for (size_t a = 0; a < std::size(kAirs); ++a) all_ratios[a].push_back(run[a] / run[0]);
    }
    std::printf("%-14s", sc->name);
    for (size_t a = 0; a < std::size(kAirs); ++a) {
      std::printf(" %7.0f (%5.0f)", Median(rates[a]), Median(per_node[a]));
    }
    std::printf("\n");
  }
  std::printf("%-14s", "all (median)");
  for (size_t a = 0; a < std::size(kAirs); ++a) {
    std::printf(" %7.0f (%5.0f)", Median(all_rates[a]), Median(all_per_node[a]));
  }
  std::printf("\n%-14s", "Mcfg/CPU s");
  for (size_t a = 0; a < std::size(kAirs); ++a) {
    std::printf(" %15.3f", 1e-6 * Median(all_configs[a]));
  }
  std::printf("\n%-14s", "ratio to still");
  for (size_t a = 0; a < std::size(kAirs); ++a) std::printf(" %15.3f", Median(all_ratios[a]));
  std::printf("\n(ratio: median over runs of wind nodes/s / still nodes/s of the same scenario "
              "and seed)\n\n");
}

void Build(const std::shared_ptr<const RiskModel>& calm) {
  const RiskMap& map = calm->map();
  const int winds = absl::GetFlag(FLAGS_winds);
  std::vector<double> model_ms, table_ms, glide_ms, still_ms;
  for (int k = 0; k < winds; ++k) {
    ModelParams p = calm->params();
    p.wind_speed_mps = 8.0;
    p.wind_from_deg = 10.0 + 360.0 * k / winds;  // a new wind each time
    double t0 = ThreadCpuSeconds();
    auto table = ImpactTable::InWind(calm->table(), p);
    double t1 = ThreadCpuSeconds();
    const WindVector w = WindVectorOf(p.wind_speed_mps, p.wind_from_deg);
    auto glide = ComputeGlideAltitude(map.nx(), map.ny(), map.res(), map.layers().terrain,
                                      map.layers().nofly, map.landing_sites(), p.glide_ratio,
                                      p.glide_clearance_m, StopCondition{},
                                      GlideWind{.x = w.x, .y = w.y,
                                                .airspeed_mps = p.GlideAirspeed()});
    const double t2 = ThreadCpuSeconds();
    glide_ms.push_back(1e3 * (t2 - t1));
    auto still = ComputeGlideAltitude(map.nx(), map.ny(), map.res(), map.layers().terrain,
                                      map.layers().nofly, map.landing_sites(), p.glide_ratio,
                                      p.glide_clearance_m, StopCondition{});
    const double t2b = ThreadCpuSeconds();
    still_ms.push_back(1e3 * (t2b - t2));
    p.wind_from_deg += 1.0;  // and the whole model in another new wind
    auto model = RiskModel::Create(calm->map_ptr(), p, calm->table_ptr());
    double t3 = ThreadCpuSeconds();
    if (!table.ok() || !glide.ok() || !still.ok() || !model.ok()) {
      std::fprintf(stderr, "building a wind's model failed\n");
      std::exit(1);
    }
    table_ms.push_back(1e3 * (t1 - t0));
    model_ms.push_back(1e3 * (t3 - t2b));
  }
  std::printf("build: a new 8 m/s wind on demo-city (%d x %d cells, %zu landing sites), %d winds, "
              "CPU ms of one thread, medians\n",
              map.nx(), map.ny(), map.landing_sites().size(), winds);
  std::printf("  ImpactTable::InWind      %8.1f ms\n", Median(table_ms));
  std::printf("  glide layer (Dijkstra)   %8.1f ms\n", Median(glide_ms));
  std::printf("  RiskModel::Create, all   %8.1f ms\n", Median(model_ms));
  std::printf("  (the still-air glide layer, for scale: %.1f ms)\n\n", Median(still_ms));
}

struct Evaluated {
  double risk = 0.0;
  double length_m = 0.0;
  bool admissible = false;
  std::string violation;
};

Evaluated Evaluate(const RiskModel& model, const std::vector<Pose>& waypoints) {
  auto pieces = PiecesFromWaypoints(waypoints, model.params());
  Evaluated e;
  if (!pieces.ok()) return e;
  auto eval = EvaluateTrajectory(model, *pieces);
  if (!eval.ok()) return e;
  e.risk = eval->risk;
  e.length_m = eval->length_m;
  e.admissible = eval->admissible;
  if (eval->first_violation.has_value()) e.violation = eval->first_violation->ToString();
  return e;
}

// `waypoints` flown with `flown_in`'s manoeuvres, as the polyline of its
// path every 5 m, evaluated in `model`: the same ground track in another air
// (the turns are not re-flown with that air's radius).
Evaluated SameTrack(const RiskModel& flown_in, const RiskModel& model,
                    const std::vector<Pose>& waypoints) {
  Evaluated e;
  auto pieces = PiecesFromWaypoints(waypoints, flown_in.params());
  if (!pieces.ok()) return e;
  std::vector<Point3> points;
  for (const TrajectoryPiece& piece : *pieces) {
    const int n = std::max(1, static_cast<int>(std::ceil(piece.Length() / 5.0)));
    for (int k = points.empty() ? 0 : 1; k <= n; ++k) {
      const Pose q = piece.PoseAt(piece.Length() * k / n);
      points.push_back({q.x, q.y, q.z});
    }
  }
  auto line = PiecesFromPolyline(points, points.size() + 1);
  if (!line.ok()) return e;
  auto eval = EvaluateTrajectory(model, *line);
  if (!eval.ok()) return e;
  e.risk = eval->risk;
  e.length_m = eval->length_m;
  e.admissible = eval->admissible;
  return e;
}

std::optional<PlanImprovement> PlanIn(const std::shared_ptr<const RiskModel>& model,
                                      const Pose& start, const Pose& goal) {
  auto planner = MakePlanner(PlannerAlgorithm::kRiskRrtStar);
  PlanOptions options;
  options.budget.max_time_s = 0.0;
  options.budget.max_iterations = absl::GetFlag(FLAGS_blind_iterations);
  options.seed = 1;
  CancellationToken cancel;
  auto result = (*planner)->Plan({model, start, goal}, options, cancel, nullptr);
  if (!result.ok()) {
    std::fprintf(stderr, "%s\n", std::string(result.status().message()).c_str());
    std::exit(1);
  }
  return result->best;
}

void Blind(const std::shared_ptr<const RiskModel>& calm,
           const std::vector<bench::Scenario>& all) {
  struct Case {
    std::string name;
    Pose start;
    Pose goal;
  };
  std::vector<Case> cases = {
      {"demo", Pose{1200, 1500, 250, 0.785}, Pose{6800, 6500, 250, 0.785}}};
  for (absl::string_view name : absl::StrSplit(absl::GetFlag(FLAGS_blind_scenarios), ',')) {
    const bench::Scenario* s = Find(all, name);
    cases.push_back({s->name, s->start, s->goal});
  }
  std::printf("blind: RISK_RRT_STAR, %lld iterations, seed 1; risks in expected casualties per "
              "flight\n",
              static_cast<long long>(absl::GetFlag(FLAGS_blind_iterations)));
  std::printf("%-12s %-14s %12s %12s %12s %8s %12s %12s\n", "scenario", "wind", "still plan",
              "it in wind", "wind plan", "blind x", "wind plan", "its admis.");
  std::printf("%-12s %-14s %12s %12s %12s %8s %12s %12s\n", "", "", "in still", "", "in wind", "",
              "in still", "in still");
  const std::optional<PlanImprovement> none;
  for (const Case& c : cases) {
    const std::optional<PlanImprovement> still = PlanIn(calm, c.start, c.goal);
    for (size_t a = 1; a < std::size(kAirs); ++a) {
      const auto wind = ModelIn(calm, kAirs[a]);
      const std::optional<PlanImprovement> windy = PlanIn(wind, c.start, c.goal);
      const Evaluated blind = still ? Evaluate(*wind, still->waypoints) : Evaluated{};
      const Evaluated back = windy ? Evaluate(*calm, windy->waypoints) : Evaluated{};
      std::printf("%-12s %-14s %12.4e %12.4e%s %12.4e %8.2f %12.4e %12s\n", c.name.c_str(),
                  kAirs[a].name, still ? still->risk : NAN, still ? blind.risk : NAN,
                  still && !blind.admissible ? "*" : " ", windy ? windy->risk : NAN,
                  still && windy ? blind.risk / windy->risk : NAN, windy ? back.risk : NAN,
                  windy ? (back.admissible ? "yes" : "no") : "-");
      const Evaluated track = still ? SameTrack(*calm, *wind, still->waypoints) : Evaluated{};
      const Evaluated track_calm = still ? SameTrack(*calm, *calm, still->waypoints) : Evaluated{};
      std::printf("    the still plan's ground track (R manoeuvres, a 5 m polyline): %.4e in still "
                  "air, %.4e in the wind (x %.2f)%s\n",
                  track_calm.risk, track.risk, track.risk / track_calm.risk,
                  track.admissible ? "" : ", not admissible");
      std::printf("    lengths: the still plan %.0f m in still air, %.0f m flown in the wind (R_w); "
                  "the wind plan %.0f m in the wind, %.0f m in still air\n",
                  still ? still->length_m : NAN, still ? blind.length_m : NAN,
                  windy ? windy->length_m : NAN, windy ? back.length_m : NAN);
      if (still && !blind.admissible) {
        std::printf("    * the still-air plan is not admissible in this wind: %s\n",
                    blind.violation.c_str());
      }
      if (windy && !back.admissible) {
        std::printf("    the wind's plan in still air: %s\n", back.violation.c_str());
      }
    }
  }
  std::printf("(blind x: the still-air plan's risk in the wind / the wind's own plan's risk)\n");
}

int Main() {
  auto runs = bench::LoadDemoCityRuns("");
  if (!runs.ok()) {
    std::fprintf(stderr, "%s\n", std::string(runs.status().message()).c_str());
    return 1;
  }
  const std::string parts = absl::GetFlag(FLAGS_parts);
  if (Wanted(parts, "rate")) Rate(runs->model, runs->scenarios);
  if (Wanted(parts, "build")) Build(runs->model);
  if (Wanted(parts, "blind")) Blind(runs->model, runs->scenarios);
  return 0;
}

}  // namespace
}  // namespace riskplan

int main(int argc, char** argv) {
  riskplan::cmdline::ParseCommandLine(
      argc, argv,
      {.program = "riskplan-bench-wind",
       .usage = "planning in a wind on demo-city: node rate, a new wind's model, wind-blind plans "
                "(docs/benchmarks.md)."});
  return riskplan::Main();
}
