// The internals of RISK_RRT_STAR (core/planners/risk_rrt_star.h) and of the
// shared goal tree (core/planners/shared_goal_tree.h): the parameters, the
// tree and candidate edges, and the Run that holds one planning call's state.
// The Run's methods live in risk_rrt_star_run.cc (sampling and the main loop,
// extension, rewiring, reporting, refinement, the guide route),
// risk_rrt_star_missions.cc (the missions: their budgets, the bound, their
// results) and risk_rrt_star_edges.cc (neighbours, candidate edges evaluated
// in risk batches against a bound, the choice of parent). Not part of core's
// API.
#ifndef RISKPLAN_CORE_PLANNERS_RISK_RRT_STAR_RUN_H_
#define RISKPLAN_CORE_PLANNERS_RISK_RRT_STAR_RUN_H_

#include <chrono>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/base/random.h"
#include "core/flight/piece_risk.h"
#include "core/flight/trajectory.h"
#include "core/planners/cost_to_go_field.h"
#include "core/planners/flight_limits.h"
#include "core/planners/path_refiner.h"
#include "core/planners/planner.h"
#include "core/planners/planner_support.h"
#include "core/planners/risk_guide.h"
#include "core/planners/shared_goal_tree.h"
#include "core/planners/spatial_grid.h"
#include "core/risk/risk_evaluator.h"
#include "core/risk/risk_model.h"

namespace riskplan::rrt_star {

inline constexpr double kInf = std::numeric_limits<double>::infinity();

// The planner parameters of PlannerParams(kRiskRrtStar), parsed and checked.
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
  bool guide = false;           // the lattice's cost-to-go field (risk_rrt_star_guide.cc)
  double guide_field_m = 400.0;
  double guide_field_step_m = 25.0;
  int guide_field_headings = 8;
  int guide_field_levels = 1;
  // With guide: a uniform sample is drawn again (up to kInformedDraws times)
  // while the field's least cost-to-go near it exceeds this times the field
  // route's risk of the running mission with the largest (0: off).
  double guide_informed = 0.0;

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
  // The length of the piece to the parent, computed when a trajectory
  // through this node is reported, for the parent `length_parent` (-1: not
  // yet). Poses never change, so it stays valid until the node is re-parented.
  int32_t length_parent = -1;
  double edge_length = 0.0;
  // Under binding limits only (Run::SetLimits; 0 otherwise): the flight time
  // (PieceRisk::FlightTimeS, so in wind by ground speed) and the 3-D length
  // of the edge to the parent, and their sums from here to the goal along
  // the tree, kept up to date like `cost` when a node is re-parented.
  double edge_s = 0.0;
  double edge_m = 0.0;
  double to_goal_s = 0.0;
  double to_goal_m = 0.0;
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
  // Under binding limits (Run::SetLimits) only: the Lagrangian weight of the
  // edge's flight time when it is known only once complete (in wind; in
  // still air and for a length it is in `base` from the start), and, set
  // when complete, the edge's flight time, its length and base + risk +
  // late_weight * time (the total the limit is compared with).
  double late_weight = 0.0;
  double time_s = 0.0;
  double length_m = 0.0;
  double total = kInf;
};

// A parent chosen for a configuration: the node (-1: none) and the edge to it.
struct EdgeChoice {
  int32_t parent = -1;
  double risk = kInf;
  double time_s = 0.0;    // under binding limits only
  double length_m = 0.0;  // under binding limits only
};

// The refinement edits one tree iteration earns (Run::Refine) when
// `with_solution` running missions have a solution: refine_edits for up to
// kMissionsPerEditShare of them (so the single-start planner's rule), else
// refine_edits * with_solution / kMissionsPerEditShare. An iteration's sample
// and extension serve every mission, an edit one only: with many missions at
// the flat rate each gets a 1/M share of what a plan of its own would, and
// the edits are what improves a trajectory once its guide route is in the
// tree (docs/benchmarks.md, "Shared goal tree"). The divisor is measured, not
// derived: 32 missions improved about equally with 4 to 50 times the flat
// rate, and the flat rate was clearly worse.
inline constexpr size_t kMissionsPerEditShare = 4;
inline double RefineEditsPerIteration(double refine_edits, size_t with_solution) {
  if (with_solution <= kMissionsPerEditShare) return refine_edits;
  return refine_edits * static_cast<double>(with_solution) /
         static_cast<double>(kMissionsPerEditShare);
}

// One start of a Run: a mission's start pose and its own budget.
struct RunMission {
  Pose start;
  PlannerBudget budget;  // checked by CheckBudget before the run
};

// What a Run reports, each with the index of the mission in the Run's list:
// improvements (strictly decreasing risk per mission) and exactly one result
// per mission, in the order the missions end.
struct RunCallbacks {
  std::function<void(size_t mission, const PlanImprovement&)> on_improvement;
  std::function<void(size_t mission, absl::StatusOr<PlanResult> result)> on_result;
};

// One planning run: one tree grown from the goal for one or more starts, all
// state of a Plan() call (one start) or of a shared goal tree
// (core/planners/shared_goal_tree.h, several). Node 0 is the goal, nodes
// 1 ... M the missions' starts, never parents; R(start m) is mission m's
// solution. With one mission every step is exactly that of the single-start
// planner: the rules below reduce to it and draw the same random numbers.
// - Branch and bound uses Bound(): the largest R(start) among running
//   missions, +inf while any of them has none, so nothing a running mission
//   could still use is refused.
// - The goal-biased samples (a start) and the path-biased samples and
//   refinement edits (around a mission's best trajectory) go round-robin over
//   the running missions (those with a solution for the last two); an
//   iteration earns RefineEditsPerIteration edits, more with more missions
//   that have a solution. Each mission gets its own guide route, added in
//   mission order before the first iteration.
// - Each mission ends by its own budget (iterations of the shared tree,
//   and/or wall time since the run began) or when its risk is 0; then it gets
//   its result while the tree grows on for the others. The node bound, the
//   token and an evaluator's error end every running mission.
// Single-threaded; callbacks run on the caller's thread and must not re-enter.
class Run {
 public:
  // REQUIRES: at least one mission; every start and the goal admissible,
  // every budget valid (the callers check them first). `model`, `evaluator` and `cancel`
  // must outlive the Run.
  // With `initial_tree` (checked by the caller: its goal is `goal`, its
  // parents in range), the tree begins as a copy of it, its nodes after the
  // starts, and each start is connected to it before the guide routes;
  // `initial_tree` need only live until Execute() begins.
  Run(const RiskModel& model, const Pose& goal, std::vector<RunMission> missions, uint64_t seed,
      bool record_tree, const Params& params, RiskEvaluator* evaluator,
      const CancellationToken& cancel, RunCallbacks callbacks,
      const GoalTree* initial_tree = nullptr);

  // Flight limits for a single-mission run (the RISK_RRT_STAR planner; the
  // limit filter still checks what it reports). When they bind (an
  // endurance or a length limit, or MIN_TIME under a risk limit; not with
  // the front) the tree carries each node's flight time and length to the
  // goal, parents and rewiring minimise the Lagrangian R + lambda * C (C the
  // flight time, or the length under a length limit alone) with lambda
  // adapted while the run goes on, the start connects to the route that
  // fits the limits and is best by the objective, and improvements are
  // reported by the objective among routes that fit (docs/planners.md,
  // "Limits"). Otherwise nothing changes. REQUIRES: one mission; before
  // Execute().
  void SetLimits(const FlightLimits& limits);
  // After Execute() under binding limits: the last lambda (0 otherwise).
  double lambda() const { return lambda_; }
  // After Execute(): the tree's node n (0 the goal, 1 ... M the starts).
  const std::vector<Node>& nodes() const { return nodes_; }

  // Plans until every mission has ended; each gets exactly one on_result:
  // its PlanResult, or the evaluator's error.
  void Execute();

  // After Execute(): the tree without its starts, into out->nodes (the
  // other fields are the caller's). False, leaving them empty, when an
  // evaluator's error ended the run (a step may have been cut short).
  bool ExportTree(GoalTree* out) const;

 private:
  enum class MissionState { kRunning, kDone };
  struct MissionRun {
    RunMission spec;
    std::optional<std::chrono::steady_clock::time_point> deadline;
    MissionState state = MissionState::kRunning;
    std::optional<PlanImprovement> best;
    // The pieces of best's trajectory, made when a path-biased sample needs
    // them (empty: not made since best changed). A shared tree's edit can
    // lower R of every mission through its nodes, so most reported
    // trajectories are never sampled before the next replaces them.
    std::vector<TrajectoryPiece> best_pieces;
    // Under binding limits: whether best meets them, and its flight time.
    bool best_fits = false;
    double best_time_s = kInf;
    // With params_.guide: the risk of the route down the field from the
    // start (+inf: none).
    double field_route_risk = kInf;
  };

  bool Admissible(const Pose& q) const {
    return model_.CheckConfiguration(q) == ViolationKind::kNone;
  }
  static int32_t StartNode(size_t mission) { return static_cast<int32_t>(mission) + kFirstStart; }
  bool IsStart(int32_t node) const {
    return node >= kFirstStart && node < kFirstStart + static_cast<int32_t>(missions_.size());
  }
  bool Running(size_t m) const { return missions_[m].state == MissionState::kRunning; }
  // The branch-and-bound limit: the largest R(start) among running missions
  // (+inf while one of them has none).
  double Bound() const;
  double Elapsed() const;

  // Ends the missions that must end now (the token: all; the node bound:
  // all; then each by its budget or a zero risk), in mission order, and
  // narrows the StopCondition to the earliest deadline left. False when no
  // mission runs any more.
  bool UpdateMissions();
  void Finish(size_t m, StopReason reason);
  void FailRunning(const absl::Status& status);
  void ResetStop();
  // The earliest deadline of a running mission (nullopt: none has one).
  std::optional<std::chrono::steady_clock::time_point> EarliestDeadline() const;
  // The goal, the starts and initial_tree_'s nodes, into nodes_ and grid_.
  void Seed();
  // Which missions a round-robin pick may choose.
  enum class Pick { kRunning, kWithBest, kWithCost };
  // The next running mission at or after *cursor that `pick` allows (kWithBest:
  // one with a reported trajectory; kWithCost: with a finite R(start)), and
  // *cursor moved past it; -1 when there is none.
  int NextMission(size_t* cursor, Pick pick) const;

  bool SampleUniform(Pose* q);
  // SampleUniform, drawn again while the field says the sample cannot lie
  // on a route as cheap as the starts' field routes (params_.guide_informed).
  bool SampleInformed(Pose* q);
  // informed_limit_ from the running missions' field routes.
  void UpdateInformedLimit();
  bool SamplePathBiased(size_t m, Pose* q);
  // A sample; *start_of is the mission whose start it is, or -1.
  Pose Sample(int* start_of);
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
  // the run's StopCondition is reached between two batches.
  absl::Status EvaluateCandidates(std::vector<CandidateEdge>* edges, bool shared_limit,
                                  int32_t* winner);
  void SetParent(int32_t child, int32_t parent, double edge_risk, double edge_s = 0.0,
                 double edge_m = 0.0);
  // The candidate parent of `from` with the least R(n) + R(from -> n) (under
  // binding limits the least Key(n) + the edge's R + lambda * C) below
  // `bound`; choice->parent -1 when none is admissible or below.
  absl::Status BestParent(const Pose& from, const std::vector<int32_t>& candidates, double bound,
                          EdgeChoice* choice);
  // What branch and bound compares: R(n), or under binding limits
  // R(n) + lambda * C(n).
  double Key(int32_t n) const {
    return limited_ ? nodes_[n].cost + lambda_ * Penalised(n) : nodes_[n].cost;
  }
  double Penalised(int32_t n) const {
    return penalise_length_ ? nodes_[n].to_goal_m : nodes_[n].to_goal_s;
  }
  // Under binding limits. A route's rank at the start (lower is better):
  // fitting routes before the others, fitting ones by the objective (then
  // the other number), the others by R + lambda * C.
  struct RouteNumbers {
    double risk = kInf;
    double time_s = kInf;
    double length_m = kInf;
  };
  bool Fits(const RouteNumbers& r) const;
  bool RankBelow(const RouteNumbers& a, const RouteNumbers& b) const;
  RouteNumbers StartRoute(size_t m) const;
  // Moves lambda after the start's connection found `key_best`, the route
  // with the least R + lambda * C: up while it breaks the time or length
  // limit (or, for MIN_TIME, while it has slack under the risk limit), down
  // otherwise.
  void AdaptLambda(const RouteNumbers& key_best);
  // The flight time and length of the piece from -> to (PieceRisk's).
  void PieceTimeLength(const Pose& from, const Pose& to, double* time_s, double* length_m) const;
  absl::Status ConnectStartLimited(size_t m);
  std::vector<int32_t> KNearestFrom(const Pose& from, const std::vector<int32_t>& near,
                                    double max_cost) const;
  absl::Status ConnectStart(size_t m);
  absl::Status Extend(const Pose& q_new);
  // Reports every running mission whose R(start) dropped below its best.
  void MaybeReport();
  void MaybeReportMission(size_t m);
  // The tree's path from mission m's start to the goal, into path_nodes_,
  // path_poses_ and path_risks_.
  void TracePath(size_t m);
  // Local improvement of the best trajectories between tree iterations
  // (core/planners/path_refiner.h): an accepted edit becomes part of the tree (a new
  // node for its waypoint, the trajectory's nodes re-parented), so the tree's
  // R(start) is the improved risk and later samples build on it.
  absl::Status Refine();
  // Seeds the tree with mission m's coarse guide route (core/planners/risk_guide.h),
  // its waypoints added from the goal's side by the ordinary extension.
  absl::Status Guide(size_t m);
  // With params_.guide: seeds the tree with mission m's route down the goal's
  // cost-to-go field (core/planners/cost_to_go_field.h), built once per goal
  // and wind and shared through GuideFieldCache::Default(); a build that
  // does not fit in half the time left is given up and the run goes on
  // without the field.
  absl::Status GuideByField(size_t m);
  // One iteration: a sample, an extension (or a start's connection), the
  // reports and the refinement.
  absl::Status Iterate();

  static constexpr int32_t kGoal = 0;
  static constexpr int32_t kFirstStart = 1;

  const RiskModel& model_;
  const Pose goal_;
  const bool record_tree_;
  const Params params_;
  RiskEvaluator* evaluator_;
  const CancellationToken& cancel_;
  const RunCallbacks callbacks_;
  const std::chrono::steady_clock::time_point begin_;  // every time budget counts from here
  const GoalTree* initial_tree_;                       // null after Seed()
  bool failed_ = false;                                // FailRunning was called
  std::vector<MissionRun> missions_;
  size_t running_ = 0;
  StopCondition stop_;  // the token and the earliest deadline of a running mission
  Rng rng_;
  Rng refine_rng_;  // the refiner's own stream: the tree's samples do not depend on it
  PathRefiner refiner_;
  double refine_credit_ = 0.0;
  size_t start_cursor_ = 0;                   // round-robin of the goal-biased samples
  size_t path_cursor_ = 0;                    // ... of the path-biased samples
  size_t refine_cursor_ = 0;                  // ... of the refinement edits
  std::optional<CoarseRiskGrid> guide_grid_;  // built for the first guide route
  // With params_.guide: the goal's cost-to-go field, got for the first mission.
  std::shared_ptr<const CostToGoField> field_;
  bool field_unavailable_ = false;  // its build did not fit in its share of the budget
  // SampleInformed's bound on the field's cost-to-go near a sample (+inf: off).
  double informed_limit_ = kInf;
  SpatialGrid grid_;
  std::vector<Node> nodes_;
  int64_t iterations_ = 0;
  // Binding limits (SetLimits).
  bool limited_ = false;
  bool penalise_length_ = false;  // C is the length (a length limit without an endurance)
  FlightLimits limits_;
  double lambda_ = 0.0;
  double lambda_ref_ = 0.0;  // lambda's first value
  // Scratch buffers reused between iterations.
  std::vector<int32_t> path_nodes_;
  std::vector<Pose> path_poses_;
  std::vector<double> path_risks_;
  std::vector<double> path_s_;
  std::vector<double> path_m_;
  std::vector<Pose> batch_poses_;
  std::vector<ConfigurationRisk> batch_risks_;
};

// The evaluator a plan uses when its caller gives none: direct evaluation,
// or with params.risk_cache_log2 > 0 the exact cache of kernel sites.
std::unique_ptr<RiskEvaluator> OwnEvaluator(const Params& params);

}  // namespace riskplan::rrt_star

#endif  // RISKPLAN_CORE_PLANNERS_RISK_RRT_STAR_RUN_H_
