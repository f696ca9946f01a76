#include "core/planners/risk_rrt_star.h"

#include <cmath>
#include <memory>

#include "absl/strings/str_format.h"
#include "core/planners/planner_support.h"
#include "core/planners/risk_rrt_star_run.h"

namespace riskplan {
namespace rrt_star {

absl::StatusOr<Params> Params::Parse(const std::map<std::string, double>& given) {
  absl::StatusOr<PlannerParamValues> values = PlannerParamValues::Parse(
      "RISK_RRT_STAR", PlannerParams(PlannerAlgorithm::kRiskRrtStar), given);
  if (!values.ok()) return values.status();
  // Integer parameters: the table's bounds keep them well inside int.
  auto integer = [&](const char* name) {
    return static_cast<int64_t>(std::floor(values->Get(name)));
  };
  Params p;
  p.step_m = values->Get("step_m");
  p.goal_bias = values->Get("goal_bias");
  p.path_bias = values->Get("path_bias");
  p.k_near = static_cast<int>(integer("k_near"));
  p.near_radius_m = values->Get("near_radius_m");
  p.nearest_candidates = static_cast<int>(integer("nearest_candidates"));
  p.max_nodes = integer("max_nodes");
  p.risk_cache_log2 = static_cast<int>(integer("risk_cache_log2"));
  p.batch_chunk = static_cast<int>(integer("batch_chunk"));
  p.refine_edits = values->Get("refine_edits");
  p.refine_scale_m = values->Get("refine_scale_m");
  p.guide_cell_m = values->Get("guide_cell_m");
  p.guide = values->Get("guide") >= 1.0;
  p.guide_field_m = values->Get("guide_field_m");
  p.guide_field_step_m = values->Get("guide_field_step_m");
  p.guide_field_headings = static_cast<int>(integer("guide_field_headings"));
  p.guide_field_levels = static_cast<int>(integer("guide_field_levels"));
  p.guide_informed = values->Get("guide_informed");
  if (p.near_radius_m == 0.0) p.near_radius_m = 2.5 * p.step_m;
  if (p.refine_scale_m == 0.0) p.refine_scale_m = 0.5 * p.step_m;
  if (p.goal_bias + p.path_bias > 0.9) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "planner parameters goal_bias (%g) + path_bias (%g) must not exceed 0.9: uniform "
        "samples keep the search complete",
        p.goal_bias, p.path_bias));
  }
  return p;
}

}  // namespace rrt_star

namespace {

const std::vector<PlannerParamInfo>& ParamInfo() {
  static const auto* info = new std::vector<PlannerParamInfo>{
      {"step_m", 400.0, 10.0, 5000.0, "largest edge added by one extension (Delta_step), m"},
      {"goal_bias", 0.05, 0.0, 0.9, "share of samples that are the start configuration"},
      {"path_bias", 0.2, 0.0, 0.9, "share of samples drawn around the best trajectory so far"},
      {"k_near", 8, 1, 100, "neighbours considered as parents and for rewiring"},
      {"near_radius_m", 0.0, 0.0, 20000.0, "largest distance of a neighbour, m (0: 2.5 * step_m)"},
      {"nearest_candidates", 8, 1, 100,
       "Euclidean candidates ranked by Dubins length to find the nearest node"},
      {"max_nodes", 200000, 10, 300000,
       "largest tree (about 160 bytes a node); the run ends when it is reached"},
      {"batch_chunk", 16, 0, 4096,
       "midpoints per candidate edge in one risk batch; a losing edge is dropped between "
       "batches (0: whole edges, one batch per step, up to 4096 midpoints of an edge each)"},
      {"refine_edits", 8, 0, 100,
       "local edits of the best trajectory tried per tree iteration once a solution exists; "
       "a shared goal tree with S > 4 missions that have one tries S / 4 times as many "
       "(fractions accumulate; 0: off)"},
      {"refine_scale_m", 0.0, 0.0, 5000.0,
       "largest standard deviation of an edit's new waypoint, horizontally, m (0: step_m / 2)"},
      {"guide_cell_m", 100.0, 0.0, 2000.0,
       "cell of the coarse risk grid whose cheapest route seeds the tree, m (0: no guide)"},
      {"guide", 0, 0, 1,
       "1: seed the tree with the route down the goal's cost-to-go field, a coarse state "
       "lattice searched from the goal once per goal and wind and cached for every mission "
       "to it (0: off, the planner as before)"},
      {"guide_field_m", 400.0, 100.0, 2000.0, "spacing of the guide field's lattice, m"},
      {"guide_field_step_m", 25.0, 5.0, 200.0,
       "sampling step of the guide field's edge risks, m (a guide only: reported risks stay "
       "exact)"},
      {"guide_field_headings", 8, 4, 32, "track headings of the guide field's lattice"},
      {"guide_field_levels", 1, 1, 8,
       "altitude levels of the guide field's lattice, from 5 m to 120 m above the safe "
       "altitude evenly (1: 5 m)"},
      {"guide_informed", 0.0, 0.0, 10.0,
       "with guide = 1: a uniform sample is drawn again (up to 8 times) while the field's "
       "least cost-to-go near it exceeds this times the largest risk of a running mission's "
       "route down the field, so samples stay where a cheap route can pass (0: off)"},
      {"risk_cache_log2", 0, 0, 20,
       "log2 of the entries of the exact configuration-risk cache (40 B each) used when no "
       "external evaluator is given; 0 turns it off"},
  };
  return *info;
}

absl::StatusOr<PlanResult> Plan(RiskEvaluator* evaluator, const PlanningProblem& problem,
                                const PlanOptions& options, const CancellationToken& cancel,
                                const ImprovementCallback& on_improvement) {
  // The seed planners' checks (PrepareSeedPlan) in this planner's order:
  // it takes no obstacles, so those are refused before the budget is read.
  if (absl::Status s = CheckEndpoints(problem); !s.ok()) return s;
  if (absl::Status s = CheckRequestObstacles(PlannerAlgorithm::kRiskRrtStar, options); !s.ok()) {
    return s;
  }
  if (absl::Status s = CheckBudget(options.budget); !s.ok()) return s;
  auto params = rrt_star::Params::Parse(options.params);
  if (!params.ok()) return params.status();
  if (absl::Status s = CheckEdgeSamples(PlannerAlgorithm::kRiskRrtStar, problem, options);
      !s.ok()) {
    return s;
  }
  // Without an evaluator of the caller's: direct evaluation, or on request an
  // exact cache of kernel sites.
  std::unique_ptr<RiskEvaluator> own;
  if (evaluator == nullptr) {
    own = rrt_star::OwnEvaluator(*params);
    evaluator = own.get();
  }
  // The single-start planner is the shared goal tree with one mission.
  absl::StatusOr<PlanResult> result = absl::InternalError("the run gave no result");
  rrt_star::RunCallbacks callbacks;
  if (on_improvement) {
    callbacks.on_improvement = [&](size_t, const PlanImprovement& i) { on_improvement(i); };
  }
  callbacks.on_result = [&](size_t, absl::StatusOr<PlanResult> r) { result = std::move(r); };
  rrt_star::Run run(*problem.model, problem.goal, {{problem.start, options.budget}}, options.seed,
                    options.record_tree, *params, evaluator, cancel, std::move(callbacks));
  run.SetLimits(options.limits);
  run.Execute();
  return result;
}

}  // namespace

constinit const AlgorithmEntry kRiskRrtStarEntry = {&ParamInfo, &Plan};

}  // namespace riskplan
