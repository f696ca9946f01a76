// HARMONIC: harmonic control (seed 002, Girau and Boumaza): the harmonic
// potential on the map's grid (HarmonicPotential), obstacles at 1 and the goal
// at 0, relaxed until it converges, then a descent from the start's cell to
// the goal's, which is turned into waypoints joined by Dubins-airplane
// manoeuvres (PathRealizer), checked exactly, evaluated by EvaluateTrajectory
// and streamed.
//
// Planning grid: the map's cells grouped cell_factor x cell_factor (by default
// the smallest factor that keeps both sides within 512 cells: 1 up to 512 x
// 512 maps, 4 for demo-city's 1600 x 1600). A planning cell is an obstacle
// when any map cell in it cannot be flown (no-fly, empty band, or with
// flight_altitude_m a band that does not hold that altitude) or lies outside
// the map, or when it comes within clearance_m of one of the request's
// obstacle points; the start's and the goal's cells are always free.
//
// Obstacles that appear while it runs (PlanOptions::dynamic_obstacles): at
// sweep at_iteration every planning cell overlapping the area becomes an
// obstacle and the relaxation goes on from the current values (seed 002:
// "newly detected obstacles may be integrated ... during computation"). When
// the potential converges, the descent is streamed; if an obstacle is still to
// come and within the iteration budget, the sweep count jumps to its sweep
// (the sweeps in between would change nothing), the obstacle is added, and the
// potential converges again; a new trajectory is then streamed with
// `replanned` set. A trajectory that an area closes is dropped from the result.
//
// The run ends CONVERGED once the potential has converged with no obstacle to
// come, with the last streamed trajectory. If the descent stops short of the
// goal (the potential is not yet accurate enough there) the tolerance is
// divided by 100 and the relaxation goes on, down to 1e-15. When the budget
// ends before convergence, the descent on the current potential is tried once.
//
// One iteration is one sweep (both colours); tree_size is the number of
// planning cells.
#ifndef RISKPLAN_CORE_PLANNERS_HARMONIC_PLANNER_H_
#define RISKPLAN_CORE_PLANNERS_HARMONIC_PLANNER_H_

#include "core/planners/algorithm_entry.h"

namespace riskplan {

// HARMONIC for MakePlanner and PlannerParams.
extern const AlgorithmEntry kHarmonicEntry;

}  // namespace riskplan

#endif  // RISKPLAN_CORE_PLANNERS_HARMONIC_PLANNER_H_
