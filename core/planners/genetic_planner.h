// GENETIC: Cocaud's modified genetic algorithm as Bayrak and Efe implement it
// (seed 003), with the two-tier feasibility check of seed 001 in its fitness.
//
// A chromosome is `waypoints` (4) transitional waypoints between the fixed
// start and goal; the trajectory flies start, waypoints, goal, joined by
// Dubins-airplane manoeuvres, each interior heading bisecting its two chords.
// In the free-elevation mode (elevation_mode 0, seed 003's MODE I) a
// waypoint's altitude is a gene too, kept as a fraction of the admissible band
// of its cell so that every value means a flyable altitude there; in the
// fixed-elevation mode (1, MODE II) every waypoint flies at fixed_altitude_m.
//
// Each generation, as seed 003's control unit:
// - selection: `population` binary tournaments among the parents;
// - genetic operations on the winners: crossover_share (75 %) of the
//   offspring by one-point crossover of two random winners, the rest by the
//   four mutations in equal numbers: global perturb (a random waypoint
//   redrawn anywhere on the map), local perturb (redrawn in the box of its
//   neighbours), delete (moved to the midpoint of its neighbours), swap (two
//   waypoints exchanged);
// - update: parents and offspring sorted by fitness, the best `population`
//   kept;
// - premature convergence: when every chromosome is identical, all but the
//   best are drawn again.
//
// Fitness, compared lexicographically (seed 003 concatenates an 8-bit
// collision cost above a 24-bit distance cost, so any collision outweighs any
// distance):
// 1. collision cost: the cells where the straight polyline start, waypoints,
//    goal breaks the flight band in the two-tier check (TwoTierFeasibility,
//    the first detailed_segments segments on the detailed grid, the rest on
//    16 x 16 blocks); only when it is 0,
// 2. the samples of the flown trajectory that fail the exact check (spec
//    section 6, and the clearance of the request's obstacle points);
// 3. cost = (1 - risk_weight) * L / L_ref + risk_weight * R / R_ref: L the
//    flown 3-D length, R the risk sampled every risk_step_m (spec section 4's
//    midpoint rule with a coarser step), L_ref the start-goal distance (at
//    least the turning radius) and R_ref the risk, so sampled, of the straight
//    segment from start to goal (at least lambda / v * L_ref * 1e-12).
// Risks of a generation's feasible offspring go to the RiskEvaluator as one
// batch.
//
// Streaming: whenever the best chromosome's fitness improves and it is
// feasible, its trajectory is evaluated by EvaluateTrajectory and streamed.
// The stream is thus in order of decreasing fitness, not of decreasing risk:
// a shorter trajectory of slightly higher risk can follow (with risk_weight
// < 1, or because the fitness samples risk more coarsely than the reported
// risk). The run ends when the budget does (BUDGET_EXHAUSTED, or
// NO_SOLUTION).
// One iteration is one generation; tree_size counts the chromosomes evaluated.
#ifndef RISKPLAN_CORE_PLANNERS_GENETIC_PLANNER_H_
#define RISKPLAN_CORE_PLANNERS_GENETIC_PLANNER_H_

#include "core/planners/algorithm_entry.h"

namespace riskplan {

// GENETIC for MakePlanner and PlannerParams.
extern const AlgorithmEntry kGeneticEntry;

}  // namespace riskplan

#endif  // RISKPLAN_CORE_PLANNERS_GENETIC_PLANNER_H_
