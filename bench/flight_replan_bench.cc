// In-flight replanning on demo-city (issue 36): a Fly session (the server's
// FlightSession, in process, one thread, with the early sink FlightCall
// sets) flies its first plan; a circular zone (radius --zone_radius_m) is
// placed across the route --distances metres ahead of the aircraft, and the
// time from the zone's arrival to the first admissible new remainder is
// measured (its FlightPlanVersion.planning_ms), with the part spent updating
// the risk model of the moment (FlightSession::model_update_ms: the zone's
// cells closed on a no-fly layer of the model's own, the glide layer
// repaired), and the time of the version the plan settles on (an IMPROVED
// one when the 0.3 s plan beat the first). Then, from the same commit point
// on the same zone model, plans from scratch with 0.3 s, 1 s and 3 s budgets
// give the risk a longer search would reach.
//
//   riskplan-bench-flight [--trials=5] [--distances=500,1000,2000]
//                         [--replan_ms=300] [--zone_radius_m=150]
//                         [--scenarios=readme,west-east,...]
// `readme` is the README's plan (1200, 1500, 250 m to 6800, 6500, 250 m);
// the other names are bench/scenarios.h's (the OMPL comparison's set). The
// plans from scratch compute their risks as the session does (accel's exact
// kernel on the thread), so the side-by-side figures compare searches, not
// evaluators.
// Prints one line per scenario and distance and one over all: p50/p95 of the first
// version's latency and of the model update, p50 of the final version's,
// how many zones gave a version (the rest an alert) and how many an
// IMPROVED one, and the median risk ratios (first and final remainder, and
// the plans from scratch, each over the 1 s plan's).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"
#include "accel/kernel_evaluator.h"
#include "bench/scenarios.h"
#include "core/planners/planner.h"
#include "server/flight/flight_session.h"
#include "server/flight/flight_zones.h"
#include "server/models/map_registry.h"
#include "server/models/model_cache.h"

ABSL_FLAG(int, trials, 5, "sessions per distance (seeds 1..trials)");
ABSL_FLAG(std::string, distances, "500,1000,2000", "zone distances ahead of the aircraft, m");
ABSL_FLAG(int, replan_ms, 300, "the session's replanning budget, ms");
ABSL_FLAG(double, zone_radius_m, 150.0, "the zone's radius, m");
ABSL_FLAG(int, first_plan_ms, 2000, "the first plan's budget, ms");
ABSL_FLAG(std::string, scenarios, "readme",
          "comma-separated: readme (the README's plan) and bench/scenarios.h names");

namespace riskplan::server {
namespace {

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const size_t k =
      std::min(v.size() - 1, static_cast<size_t>(std::ceil(q * v.size())) - (q > 0 ? 1 : 0));
  return v[k];
}

void SetPose(const Pose& p, v1::Pose* out) {
  out->set_x(p.x);
  out->set_y(p.y);
  out->set_z(p.z);
  out->set_theta(p.theta);
}

v1::FlightInput OpenInput(const Pose& start, const Pose& goal, uint64_t seed) {
  v1::FlightInput in;
  v1::FlightOpen* open = in.mutable_open();
  v1::PlanRequest* plan = open->mutable_plan();
  plan->set_map("demo-city");
  SetPose(start, plan->mutable_start());
  SetPose(goal, plan->mutable_goal());
  plan->mutable_budget()->set_time_ms(absl::GetFlag(FLAGS_first_plan_ms));
  plan->set_seed(seed);
  open->set_commit_horizon_s(10);
  open->mutable_replan_budget()->set_time_ms(absl::GetFlag(FLAGS_replan_ms));
  return in;
}

double PlanRisk(const std::shared_ptr<const RiskModel>& model, const Pose& from, const Pose& goal,
                double seconds, uint64_t seed) {
  accel::KernelRiskEvaluator evaluator;
  auto planner = MakePlanner(PlannerAlgorithm::kRiskRrtStar, &evaluator);
  PlanOptions options;
  options.budget.max_time_s = seconds;
  options.seed = seed;
  CancellationToken never;
  auto r = (*planner)->Plan({model, from, goal}, options, never, [](const PlanImprovement&) {});
  return r.ok() && r->best.has_value() ? r->best->risk : NAN;
}

int Main() {
  auto registry = MapRegistry::DemoCity();
  if (!registry.ok()) return 1;
  auto models = RiskModelCache::Create(**registry, 4);
  if (!models.ok()) return 1;
  FlightEnv env;
  env.maps = registry->get();
  env.models = models->get();
  std::vector<double> distances;
  for (absl::string_view d : absl::StrSplit(absl::GetFlag(FLAGS_distances), ',')) {
    double v = 0;
    if (absl::SimpleAtod(d, &v)) distances.push_back(v);
  }
  struct Named {
    std::string name;
    Pose start, goal;
  };
  std::vector<Named> scenarios;
  {
    auto base = (*models)->Get(*(*registry)->Find("demo-city"), ModelParams{});
    if (!base.ok()) return 1;
    const std::vector<bench::Scenario> known = bench::DemoCityScenarios(**base);
    for (absl::string_view want : absl::StrSplit(absl::GetFlag(FLAGS_scenarios), ',')) {
      if (want == "readme") {
        scenarios.push_back({"readme", {1200, 1500, 250, 0.785}, {6800, 6500, 250, 0.785}});
        continue;
      }
      const auto it = std::find_if(known.begin(), known.end(),
                                   [&](const bench::Scenario& k) { return k.name == want; });
      if (it == known.end()) {
        std::fprintf(stderr, "unknown scenario '%s'\n", std::string(want).c_str());
        return 1;
      }
      scenarios.push_back({it->name, it->start, it->goal});
    }
  }
  std::printf(
      "scenario     distance_m trials versions first_p50_ms first_p95_ms model_p50_ms model_p95_ms "
      "final_p50_ms improved risk_first/risk_1s risk_session/risk_1s risk_0.3s/risk_1s "
      "risk_3s/risk_1s\n");
  struct Figures {
    std::vector<double> first_ms, model_ms, final_ms, first_ratio, session_ratio, r03, r3;
    int versions = 0;
    int improved = 0;
  };
  const auto print = [](const std::string& scenario, const std::string& label, int trials,
                        const Figures& f) {
    std::printf(
        "%-12s %10s %6d %8d %12.1f %12.1f %12.1f %12.1f %12.1f %8d %17.3f %20.3f %17.3f %15.3f\n",
        scenario.c_str(), label.c_str(), trials, f.versions, Quantile(f.first_ms, 0.5),
        Quantile(f.first_ms, 0.95), Quantile(f.model_ms, 0.5), Quantile(f.model_ms, 0.95),
        Quantile(f.final_ms, 0.5), f.improved, Quantile(f.first_ratio, 0.5),
        Quantile(f.session_ratio, 0.5), Quantile(f.r03, 0.5), Quantile(f.r3, 0.5));
    std::fflush(stdout);
  };
  Figures all;
  for (const Named& sc : scenarios) {
    for (double distance : distances) {
      Figures f;
      for (int trial = 1; trial <= absl::GetFlag(FLAGS_trials); ++trial) {
        FlightSession session(env);
        // As FlightCall does: a change's first admissible remainder goes out at once.
        std::vector<v1::FlightOutput> outputs;
        session.set_early_sink([&](v1::FlightOutput o) { outputs.push_back(std::move(o)); });
        CancellationToken never;
        auto opened = session.Handle(OpenInput(sc.start, sc.goal, trial), never);
        if (!opened.ok() || opened->empty() || !opened->front().has_plan()) continue;
        const v1::Trajectory& route = opened->front().plan().route();
        const double step = route.length_m() / (route.path_size() - 1);
        const int at =
            std::min(route.path_size() - 1, static_cast<int>(std::lround(distance / step)));
        const v1::Pose& p = route.path(at);
        v1::FlightInput zone;
        zone.mutable_add_zone()->set_id("zone");
        zone.mutable_add_zone()->mutable_circle()->set_x(p.x());
        zone.mutable_add_zone()->mutable_circle()->set_y(p.y());
        zone.mutable_add_zone()->mutable_circle()->set_radius_m(absl::GetFlag(FLAGS_zone_radius_m));
        outputs.clear();
        auto out = session.Handle(zone, never);
        if (!out.ok()) continue;
        for (v1::FlightOutput& o : *out) outputs.push_back(std::move(o));
        if (outputs.empty() || !outputs.front().has_plan()) continue;
        ++f.versions;
        // The first admissible new remainder, and the one the plan settled on.
        const v1::FlightPlanVersion& first = outputs.front().plan();
        const v1::FlightPlanVersion& last =
            outputs.back().has_plan() ? outputs.back().plan() : first;
        if (last.reason() == v1::FLIGHT_REASON_IMPROVED) ++f.improved;
        f.first_ms.push_back(first.planning_ms());
        f.model_ms.push_back(session.model_update_ms());
        f.final_ms.push_back(last.planning_ms());
        const std::shared_ptr<const RiskModel> zmodel = session.model();
        // Plans from scratch from the same commit point, on the same zone model.
        const Pose commit = session.route()[session.committed_count() - 1];
        const Pose& goal = sc.goal;
        const double risk03 = PlanRisk(zmodel, commit, goal, 0.3, trial);
        const double risk1 = PlanRisk(zmodel, commit, goal, 1.0, trial);
        const double risk3 = PlanRisk(zmodel, commit, goal, 3.0, trial);
        f.first_ratio.push_back(first.remainder().risk() / risk1);
        f.session_ratio.push_back(last.remainder().risk() / risk1);
        f.r03.push_back(risk03 / risk1);
        f.r3.push_back(risk3 / risk1);
      }
      print(sc.name, absl::StrFormat("%.0f", distance), absl::GetFlag(FLAGS_trials), f);
      for (auto [from, to] : {std::pair{&f.first_ms, &all.first_ms},
                              {&f.model_ms, &all.model_ms},
                              {&f.final_ms, &all.final_ms},
                              {&f.first_ratio, &all.first_ratio},
                              {&f.session_ratio, &all.session_ratio},
                              {&f.r03, &all.r03},
                              {&f.r3, &all.r3}}) {
        to->insert(to->end(), from->begin(), from->end());
      }
      all.versions += f.versions;
      all.improved += f.improved;
    }
  }
  print("all", "all",
        absl::GetFlag(FLAGS_trials) * static_cast<int>(distances.size() * scenarios.size()), all);
  return 0;
}

}  // namespace
}  // namespace riskplan::server

int main(int argc, char** argv) {
  absl::ParseCommandLine(argc, argv);
  return riskplan::server::Main();
}
