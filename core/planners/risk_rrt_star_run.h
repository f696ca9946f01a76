// The internals of RISK_RRT_STAR (core/planners/risk_rrt_star.h): its
// parameters, its tree and candidate edges, and the Run that holds one Plan()
// call's state. The Run's methods live in risk_rrt_star_run.cc (sampling and
// the main loop, extension, rewiring, reporting, refinement, the guide route)
// and risk_rrt_star_edges.cc (neighbours, candidate edges evaluated in risk
// batches against a bound, the choice of parent). Not part of core's API.
#ifndef RISKPLAN_CORE_PLANNERS_RISK_RRT_STAR_RUN_H_
#define RISKPLAN_CORE_PLANNERS_RISK_RRT_STAR_RUN_H_

#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/base/random.h"
#include "core/flight/piece_risk.h"
#include "core/flight/trajectory.h"
#include "core/planners/path_refiner.h"
#include "core/planners/planner.h"
#include "core/planners/planner_support.h"
#include "core/planners/spatial_grid.h"
#include "core/risk/risk_evaluator.h"
#include "core/risk/risk_model.h"

namespace riskplan::rrt_star {

inline constexpr double kInf = std::numeric_limits<double>::infinity();

// The planner parameters of RiskRrtStar::ParamInfo(), parsed and checked.
struct Params {
  double step_m = 400.0;
  double goal_bias = 0.05;
  double path_bias = 0.2;
  int k_near = 8;
  double near_radius_m = 0.0;  // 0 in the request: 2.5 * step_m
  int nearest_candidates = 8;
  int64_t max_nodes = 200000;
  int risk_cache_log2 = 0;
  int batch_chunk = 16;         // 0: whole edges
  double refine_edits = 8;      // fractions accumulate between iterations
  double refine_scale_m = 0.0;  // 0 in the request: step_m / 2
  double guide_cell_m = 100.0;  // 0: no guide route

  // The defaults overridden by `given` (PlannerParamValues::Parse's checks),
  // integer parameters rounded down, and goal_bias + path_bias <= 0.9.
  static absl::StatusOr<Params> Parse(const std::map<std::string, double>& given);

  // Midpoints of one candidate edge per risk batch: batch_chunk, or with 0
  // kMaxBatchChunk, which holds every midpoint of any edge but the longest
  // (so that a batch of k_near edges stays a few tens of MB however long
  // they are; the outcome does not depend on the chunking).
  static constexpr int64_t kMaxBatchChunk = 4096;
  int64_t MidpointsPerBatch() const { return batch_chunk > 0 ? batch_chunk : kMaxBatchChunk; }
};

struct Node {
  Pose pose;
  int32_t parent = -1;
  double cost = kInf;       // R(q): risk from here to the goal along the tree
  double edge_risk = kInf;  // risk of the edge to the parent (a piece risk)
  std::vector<int32_t> children;
};

// A candidate edge, evaluated progressively: its midpoints are generated,
// checked and sent to the risk batches a chunk at a time, and it is dropped as
// soon as a midpoint is inadmissible or base + its partial risk reaches its
// limit (risk only grows as samples are added), so a losing edge costs only
// the chunks it took to lose.
struct CandidateEdge {
  CandidateEdge(int32_t node, PieceRisk rule, double base, double limit)
      : node(node), rule(std::move(rule)), base(base), limit(limit) {}

  int32_t node = -1;     // the tree node at the other end
  PieceRisk rule;        // the edge's piece, its midpoints and their sum so far
  double base = 0.0;     // risk added to the edge's own: R of its far end
  double limit = kInf;   // drop when base + partial risk >= limit
  int64_t in_batch = 0;  // midpoints of this edge in the current batch
  bool alive = true;
  bool admissible = true;  // false once an inadmissible midpoint was found
  double risk = kInf;      // set when complete: exactly the piece risk of EvaluateTrajectory
};

// One planning run: all state of a Plan() call.

// One planning run: all state of a Plan() call.
class Run {
 public:
  Run(const PlanningProblem& problem, const PlanOptions& options, const Params& params,
      RiskEvaluator* evaluator, const CancellationToken& cancel,
      const ImprovementCallback& on_improvement)
      : problem_(problem),
        model_(*problem.model),
        options_(options),
        params_(params),
        evaluator_(evaluator),
        cancel_(cancel),
        on_improvement_(on_improvement),
        limits_(options.budget, cancel),
        stop_(limits_.Stop()),
        rng_(options.seed),
        refine_rng_(options.seed ^ 0x5265666e65526e67ULL),
        refiner_(model_, evaluator, params.refine_scale_m, params.MidpointsPerBatch(), stop_),
        grid_(model_.map().x0(), model_.map().y0(), model_.map().width_m(), model_.map().height_m(),
              std::max(50.0, params.near_radius_m / 2.0)) {}

  absl::StatusOr<PlanResult> Execute();

 private:
  bool Admissible(const Pose& q) const {
    return model_.CheckConfiguration(q) == ViolationKind::kNone;
  }
  bool BudgetLeft() const {
    if (limits_.OutOfIterations(iterations_) || limits_.OutOfTime()) return false;
    return static_cast<int64_t>(nodes_.size()) < params_.max_nodes;
  }
  double BestCost() const { return nodes_[kStart].cost; }

  bool SampleUniform(Pose* q);
  bool SamplePathBiased(Pose* q);
  Pose Sample(bool* is_start);
  int32_t NearestNode(const Pose& q) const;
  std::vector<int32_t> NearCandidates(const Pose& q) const;
  // Appends the edge flown from `from` to `to`; its midpoints are generated
  // and checked by EvaluateCandidates.
  void AddCandidate(const Pose& from, const Pose& to, int32_t node, double base, double limit,
                    std::vector<CandidateEdge>* edges) const;
  // Evaluates the edges progressively, dropping each as soon as a midpoint is
  // inadmissible or base + partial risk reaches its limit; with `shared_limit`
  // the limit is the best total base + risk completed so far (starting at the
  // edges' limit), and *winner is the index of the edge that set it (-1: none).
  // An edge that completes is admissible and has exactly the risk a full
  // evaluation of admissible edges alone would give it, so the outcome does
  // not depend on when an inadmissible edge is found out. RunStopped() when
  // the run's budget ends or its token is cancelled between two batches.
  absl::Status EvaluateCandidates(std::vector<CandidateEdge>* edges, bool shared_limit,
                                  int32_t* winner);
  void SetParent(int32_t child, int32_t parent, double edge_risk);
  // The candidate parent of `from` with the least R(n) + R(from -> n) below
  // `bound`, as (node, edge risk); node -1 when none is admissible or below.
  absl::Status BestParent(const Pose& from, const std::vector<int32_t>& candidates, double bound,
                          int32_t* parent, double* edge_risk);
  std::vector<int32_t> KNearestFrom(const Pose& from, const std::vector<int32_t>& near,
                                    double max_cost) const;
  absl::Status ConnectStart();
  absl::Status Extend(const Pose& q_new);
  absl::Status MaybeReport();
  // Local improvement of the best trajectory between tree iterations
  // (core/planners/path_refiner.h): an accepted edit becomes part of the tree (a new
  // node for its waypoint, the trajectory's nodes re-parented), so the tree's
  // R(start) is the improved risk and later samples build on it.
  absl::Status Refine();
  // Seeds the tree with the coarse guide route (core/planners/risk_guide.h), its
  // waypoints added from the goal's side by the ordinary extension.
  absl::Status Guide();

  static constexpr int32_t kGoal = 0;
  static constexpr int32_t kStart = 1;

  const PlanningProblem& problem_;
  const RiskModel& model_;
  const PlanOptions& options_;
  const Params params_;
  RiskEvaluator* evaluator_;
  const CancellationToken& cancel_;
  const ImprovementCallback& on_improvement_;
  RunLimits limits_;  // the budget's clock starts when the run is made
  const StopCondition stop_;  // limits_'s, polled between risk batches
  Rng rng_;
  Rng refine_rng_;  // the refiner's own stream: the tree's samples do not depend on it
  PathRefiner refiner_;
  double refine_credit_ = 0.0;
  SpatialGrid grid_;
  std::vector<Node> nodes_;
  int64_t iterations_ = 0;
  std::optional<PlanImprovement> best_;
  std::vector<TrajectoryPiece> best_pieces_;
  // Scratch buffers reused between iterations.
  std::vector<int32_t> path_nodes_;
  std::vector<Pose> path_poses_;
  std::vector<double> path_risks_;
  std::vector<Pose> batch_poses_;
  std::vector<ConfigurationRisk> batch_risks_;
};

}  // namespace riskplan::rrt_star

#endif  // RISKPLAN_CORE_PLANNERS_RISK_RRT_STAR_RUN_H_
