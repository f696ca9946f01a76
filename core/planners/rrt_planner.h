// RRT: plain RRT with point obstacles (seed 004, Shang et al., Algorithm 1).
//
// The tree grows in the horizontal plane from the start. Each iteration draws
// a random point of the map (the goal itself with probability goal_bias),
// finds the nearest vertex, and steps step_m (delta) from it towards the
// point; as in the seed, a point closer than delta to its nearest vertex is
// drawn again (with keep_growing the point itself is taken, or the tree would
// stop growing once its vertices cover the map). The new edge is accepted only
// if every obstacle point lies farther than clearance_m (xi) from it.
// Obstacle points are the map's (the centres of the border cells of every
// region that cannot be flown: no-fly cells, and cells whose admissible band
// is empty or, with flight_altitude_m, does not hold that altitude; see
// MapObstaclePoints) and the request's (PlanOptions::obstacle_points).
//
// A vertex within delta of the goal whose edge to the goal is clear connects:
// the branch from the start is turned into waypoints joined by Dubins-airplane
// manoeuvres (PathRealizer), checked exactly and evaluated by
// EvaluateTrajectory, and streamed. By default the run then ends (CONVERGED:
// seed 004 stops at the first connection); with keep_growing = 1 the tree
// keeps growing until the budget ends and every later connection whose
// trajectory has a lower risk is streamed too. A connection whose branch
// cannot be flown (the realizer fails) is skipped and the tree grows on.
//
// Edges that start at the start, or end at the goal, are checked against the
// map's points with min(xi, 0.99 x the distance from that end to the nearest
// map point), so that a start next to a no-fly zone is not walled in by its
// own clearance; the request's points apply in full, and a start or goal
// within xi of one of them is an InvalidArgument error.
//
// One iteration is one drawn point; tree_size counts the vertices.
#ifndef RISKPLAN_CORE_PLANNERS_RRT_PLANNER_H_
#define RISKPLAN_CORE_PLANNERS_RRT_PLANNER_H_

#include "core/planners/algorithm_entry.h"

namespace riskplan {

// RRT for MakePlanner and PlannerParams.
extern const AlgorithmEntry kRrtEntry;

}  // namespace riskplan

#endif  // RISKPLAN_CORE_PLANNERS_RRT_PLANNER_H_
