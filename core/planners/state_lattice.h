// StateLattice: an offline, resolution-complete planner over a lattice of
// position x heading x altitude level, for a reference optimum and for the
// cost-to-go field that guides RISK_RRT_STAR (core/planners/cost_to_go_field.h).
//
// States: the centres of a square grid of `spacing_m` over the map, each with
// `headings` equally spaced track headings and one altitude per entry of
// `level_offsets_m` (that far above the cell's safe altitude, at most its
// ceiling). A state whose pose is not admissible (spec section 6) is left out.
// Motion primitives: from heading h to h - 1, h or h + 1, towards one of the
// 16 neighbours of the grid (8 adjacent, 8 a knight's move away), at any
// level, kept when the planar Dubins path of the manoeuvre is at most 1.25
// times the straight distance (no loops). Every edge is the Dubins-airplane
// manoeuvre of spec section 5 with the wind's R_w and gamma_w
// (ModelParams::GroundTurnRadius/GroundClimbAngle), and its cost is the
// exact piece risk (core/flight/piece_risk.h) sampled every `risk_step_m`
// (0: the model's sample_step_m, so that the cost is what EvaluateTrajectory
// gives), computed through a RiskEvaluator in batches. An edge with an
// inadmissible sample is not an edge.
//
// The start and the goal need not be states: each is joined to every state
// within `connect_radius_m` (0: 2 spacings) whose manoeuvre is not a loop
// (planar length at most 1.3 x the distance + R_w), and to each other when
// they are that close.
//
// Solve() runs Dijkstra from the goal over reversed edges until no state left
// can beat the best start connection found, so its route is the cheapest of
// the lattice's (ties by state index). Its risk is the sum of the pieces'
// risks from the start (the order of EvaluateTrajectory), so with the exact
// step it equals EvaluateTrajectory's risk for its waypoints bit for bit.
// Field() runs the same search to exhaustion and keeps every state's
// cost-to-go and next state.
//
// Edge risks are remembered between calls (they depend on the model only), so
// several goals on one lattice share the work; MemoryBytes() counts them.
// Deterministic; not thread-safe (Solve and Field write the memo).
#ifndef RISKPLAN_CORE_PLANNERS_STATE_LATTICE_H_
#define RISKPLAN_CORE_PLANNERS_STATE_LATTICE_H_

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/cancellation.h"
#include "core/base/geometry.h"
#include "core/risk/risk_evaluator.h"
#include "core/risk/risk_model.h"

namespace riskplan {

struct LatticeOptions {
  double spacing_m = 250.0;                           // grid of positions, m; [10, map side]
  int headings = 8;                                   // track headings, [4, 64]
  std::vector<double> level_offsets_m = {3.0, 25.0};  // above the safe altitude, m; 1 to 8, >= 0
  double risk_step_m = 0.0;       // 0: the model's sample_step_m; else >= sample_step_m
  double connect_radius_m = 0.0;  // 0: 2 * spacing_m
};

// InvalidArgument naming the field (and index) of a bad option.
absl::Status CheckLatticeOptions(const LatticeOptions& options);

struct LatticeRoute {
  std::vector<Pose> waypoints;  // start, lattice states ..., goal
  double risk = 0.0;            // sum of the pieces' risks from the start
  double length_m = 0.0;
};

struct LatticeSearchStats {
  int64_t states_settled = 0;
  int64_t edges_evaluated = 0;  // piece risks computed (not remembered)
  uint64_t configurations = 0;  // midpoints sent to the evaluator
};

// A cost-to-go field: for every state its cheapest risk to the goal over the
// lattice and the next state on the way (kToGoal: the goal itself).
struct LatticeField {
  static constexpr int32_t kNone = -1;
  static constexpr int32_t kToGoal = -2;
  Pose goal;
  std::vector<double> cost;  // +inf: no route
  std::vector<int32_t> next;
  size_t MemoryBytes() const {
    return cost.capacity() * sizeof(double) + next.capacity() * sizeof(int32_t);
  }
};

class StateLattice {
 public:
  // The states and primitives of `model` under `options` (CheckLatticeOptions).
  // `model` must outlive the lattice's Solve and Field calls (RouteDown
  // takes its model as an argument, so a lattice may outlive its model).
  static absl::StatusOr<std::unique_ptr<StateLattice>> Create(const RiskModel& model,
                                                              const LatticeOptions& options);

  const LatticeOptions& options() const { return options_; }
  int64_t state_count() const { return static_cast<int64_t>(poses_.size()); }
  int64_t valid_states() const { return valid_states_; }
  bool valid(int32_t s) const { return valid_[s] != 0; }
  const Pose& pose(int32_t s) const { return poses_[s]; }
  // Primitives into a state of one heading (the same for every heading).
  size_t primitives_per_heading() const { return into_[0].size(); }
  // The grid positions: states p * states_per_position() up to the next
  // position's are those of position p (every heading and level).
  int64_t position_count() const { return static_cast<int64_t>(nx_) * ny_; }
  int states_per_position() const { return options_.headings * levels_; }
  // The grid position whose square holds (x, y) (the last row or column for
  // the strip of the map past the grid), -1 off the map.
  int64_t PositionNear(double x, double y) const;

  // The cheapest lattice route from `start` to `goal` (both admissible:
  // callers check them), or nullopt when the lattice joins them by none.
  // Errors from the evaluator, and Cancelled once `stop` is reached.
  absl::StatusOr<std::optional<LatticeRoute>> Solve(const Pose& start, const Pose& goal,
                                                    RiskEvaluator* evaluator,
                                                    const StopCondition& stop = {},
                                                    LatticeSearchStats* stats = nullptr);

  // Every state's cost-to-go to `goal`.
  absl::StatusOr<LatticeField> Field(const Pose& goal, RiskEvaluator* evaluator,
                                     const StopCondition& stop = {},
                                     LatticeSearchStats* stats = nullptr);

  // The route from `start` down `field` (built by this lattice) under
  // `model` (the lattice's, or one of the same map and parameters): the
  // start's best connection (edge risk + cost-to-go), then the next states
  // to the goal. Reads no memo, so it may run on many threads at once. Its
  // risk is the sum of its edges' risks at risk_step_m.
  absl::StatusOr<std::optional<LatticeRoute>> RouteDown(const RiskModel& model,
                                                        const LatticeField& field,
                                                        const Pose& start,
                                                        RiskEvaluator* evaluator) const;

  // The remembered edge risks, dropped (a lattice kept only for RouteDown).
  void DropMemo();
  size_t MemoryBytes() const;

 private:
  struct Primitive {
    int di = 0;
    int dj = 0;
    int from_heading = 0;
  };
  struct Edge {
    Pose from;
    Pose to;
    double risk = 0.0;  // +inf: not admissible
  };

  StateLattice(const RiskModel& model, const LatticeOptions& options);
  double RiskStep(const RiskModel& m) const;
  int32_t StateOf(int i, int j, int h, int l) const {
    return ((j * nx_ + i) * options_.headings + h) * levels_ + l;
  }
  // Prices `edges` (exact piece risk at RiskStep(), +inf when a midpoint is
  // not admissible), in batches.
  absl::Status PriceEdges(const RiskModel& m, std::vector<Edge>* edges, RiskEvaluator* evaluator,
                          LatticeSearchStats* stats) const;
  // States within the connection radius of `p`, with the edges p -> state
  // (from_p) or state -> p, filtered against loops.
  std::vector<int32_t> NearStates(const RiskMap& map, const Pose& p) const;
  static bool NotALoop(const RiskModel& m, const Pose& a, const Pose& b);
  // Dijkstra from `goal`; stops when the least cost queued reaches *bound
  // (updated from `start_edges`: state -> risk of start -> state).
  absl::Status Search(const Pose& goal, const std::vector<std::pair<int32_t, double>>& start_edges,
                      double* bound, int32_t* best_first, LatticeField* field,
                      RiskEvaluator* evaluator, const StopCondition& stop,
                      LatticeSearchStats* stats);
  // Waypoints and the forward risk sum of start -> first -> ... -> goal.
  absl::StatusOr<LatticeRoute> Trace(const RiskModel& m, const Pose& start,
                                     const LatticeField& field, int32_t first,
                                     RiskEvaluator* evaluator) const;

  const RiskModel* model_;  // Solve and Field only
  LatticeOptions options_;
  double x0_ = 0.0;  // the map's corner
  double y0_ = 0.0;
  double width_m_ = 0.0;
  double height_m_ = 0.0;
  int nx_ = 0;
  int ny_ = 0;
  int levels_ = 0;
  std::vector<Pose> poses_;
  std::vector<uint8_t> valid_;
  int64_t valid_states_ = 0;
  std::vector<std::vector<Primitive>> into_;  // per heading: primitives ending in it
  size_t max_into_ = 0;
  // Risk of predecessor edge (prim, level) into state s:
  // memo_[s * max_into_ * levels_ + prim * levels_ + level]; NaN: not yet.
  std::vector<double> memo_;
};

}  // namespace riskplan

#endif  // RISKPLAN_CORE_PLANNERS_STATE_LATTICE_H_
