// In-flight replanning on demo-city (issue 36): a Fly session (the server's
// FlightSession, in process, one thread) flies its first plan; a circular
// zone (radius --zone_radius_m) is placed across the route --distances metres
// ahead of the aircraft, and the time from the zone's arrival to the first
// admissible new remainder is measured (FlightPlanVersion.planning_ms), with
// its two parts: the risk model of the moment (the map with the zone closed,
// its glide layer computed again) and the plan from the commit point.
// Then, from the same commit point on the same zone model, plans from
// scratch with 0.3 s, 1 s and 3 s budgets give the risk a longer search
// would reach (the session's replanning is such a plan from scratch today).
//
//   riskplan-bench-flight [--trials=5] [--distances=500,1000,2000]
//                         [--replan_ms=300] [--zone_radius_m=150]
// Prints one line per distance: p50/p95 of the latency, how many zones
// gave a version (the rest an alert), and the median risk ratios.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"
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

namespace riskplan::server {
namespace {

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(std::ceil(q * v.size())) - (q > 0 ? 1 : 0));
  return v[k];
}

v1::FlightInput OpenInput(uint64_t seed) {
  v1::FlightInput in;
  v1::FlightOpen* open = in.mutable_open();
  v1::PlanRequest* plan = open->mutable_plan();
  plan->set_map("demo-city");
  plan->mutable_start()->set_x(1200);
  plan->mutable_start()->set_y(1500);
  plan->mutable_start()->set_z(250);
  plan->mutable_start()->set_theta(0.785);
  plan->mutable_goal()->set_x(6800);
  plan->mutable_goal()->set_y(6500);
  plan->mutable_goal()->set_z(250);
  plan->mutable_goal()->set_theta(0.785);
  plan->mutable_budget()->set_time_ms(absl::GetFlag(FLAGS_first_plan_ms));
  plan->set_seed(seed);
  open->set_commit_horizon_s(10);
  open->mutable_replan_budget()->set_time_ms(absl::GetFlag(FLAGS_replan_ms));
  return in;
}

double PlanRisk(const std::shared_ptr<const RiskModel>& model, const Pose& from, const Pose& goal,
                double seconds, uint64_t seed, double* first_s = nullptr) {
  auto planner = MakePlanner(PlannerAlgorithm::kRiskRrtStar);
  PlanOptions options;
  options.budget.max_time_s = seconds;
  options.seed = seed;
  CancellationToken never;
  const absl::Time t0 = absl::Now();
  bool first = true;
  auto r = (*planner)->Plan({model, from, goal}, options, never, [&](const PlanImprovement&) {
    if (first && first_s != nullptr) *first_s = absl::ToDoubleSeconds(absl::Now() - t0);
    first = false;
  });
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
  std::printf("distance_m trials versions latency_p50_ms latency_p95_ms model_p50_ms plan_p50_ms "
              "risk_session/risk_1s risk_0.3s/risk_1s risk_3s/risk_1s\n");
  for (double distance : distances) {
    std::vector<double> latency, model_ms, plan_ms, session_ratio, r03, r3;
    int versions = 0;
    for (int trial = 1; trial <= absl::GetFlag(FLAGS_trials); ++trial) {
      FlightSession session(env);
      CancellationToken never;
      auto opened = session.Handle(OpenInput(trial), never);
      if (!opened.ok() || opened->empty() || !opened->front().has_plan()) continue;
      const v1::Trajectory& route = opened->front().plan().route();
      const double step = route.length_m() / (route.path_size() - 1);
      const int at = std::min(route.path_size() - 1, static_cast<int>(std::lround(distance / step)));
      const v1::Pose& p = route.path(at);
      v1::FlightInput zone;
      zone.mutable_add_zone()->set_id("zone");
      zone.mutable_add_zone()->mutable_circle()->set_x(p.x());
      zone.mutable_add_zone()->mutable_circle()->set_y(p.y());
      zone.mutable_add_zone()->mutable_circle()->set_radius_m(absl::GetFlag(FLAGS_zone_radius_m));
      auto out = session.Handle(zone, never);
      if (!out.ok() || out->empty()) continue;
      if (!out->front().has_plan()) continue;
      ++versions;
      const v1::FlightPlanVersion& v = out->front().plan();
      latency.push_back(v.planning_ms());
      model_ms.push_back(session.model_update_ms());
      plan_ms.push_back(v.planning_ms() - model_ms.back());
      const std::shared_ptr<const RiskModel> zmodel = session.model();
      // Plans from scratch from the same commit point, on the same zone model.
      const Pose commit = session.route()[session.committed_count() - 1];
      const Pose goal{6800, 6500, 250, 0.785};
      double first_s = NAN;
      const double risk03 = PlanRisk(zmodel, commit, goal, 0.3, trial, &first_s);
      std::printf("# first solution of the 0.3 s plan after %.1f ms\n", first_s * 1e3);
      const double risk1 = PlanRisk(zmodel, commit, goal, 1.0, trial);
      const double risk3 = PlanRisk(zmodel, commit, goal, 3.0, trial);
      session_ratio.push_back(v.remainder().risk() / risk1);
      r03.push_back(risk03 / risk1);
      r3.push_back(risk3 / risk1);
    }
    std::printf("%10.0f %6d %8d %14.1f %14.1f %12.1f %11.1f %21.3f %17.3f %15.3f\n", distance,
                absl::GetFlag(FLAGS_trials), versions, Quantile(latency, 0.5),
                Quantile(latency, 0.95), Quantile(model_ms, 0.5), Quantile(plan_ms, 0.5),
                Quantile(session_ratio, 0.5), Quantile(r03, 0.5), Quantile(r3, 0.5));
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace
}  // namespace riskplan::server

int main(int argc, char** argv) {
  absl::ParseCommandLine(argc, argv);
  return riskplan::server::Main();
}
