// RISK_RRT_STAR: the anytime Risk-based RRT* (Algorithm 2 of the thesis in
// shared/seeds/000, after Slama, Vana, Faigl, CASE 2021).
//
// The tree grows from the goal; every node stores R(q), the risk of flying
// from q to the goal along the tree. A new configuration is steered towards a
// sample from its nearest node (by Dubins-airplane length), takes the parent
// among its k nearest that minimises R(parent) + R(q_new -> parent) over
// admissible edges, and then rewires its neighbours through itself when that
// lowers their risk, propagating the change to their descendants. The start is
// a node of the tree that is never a parent; its risk is the current solution.
// Unlike the thesis's loop the planner does not stop at the first connection:
// it keeps improving until the budget ends and reports each improvement.
//
// Speed-ups, all valid for a risk cost (docs/planners.md says why):
// - candidate edges of one step are evaluated as one risk batch, and only
//   after their (cheap) admissibility check has passed;
// - branch and bound: with the admissible heuristic h = 0 (risk is never
//   negative), no edge is evaluated towards a node, and no node is added,
//   whose risk already reaches the best solution's;
// - path-biased sampling: a share of the samples is drawn around the current
//   best trajectory, while uniform samples keep the search complete;
// - a guide route: before the first iteration, the cheapest route over a
//   coarse grid of configuration risks (core/planners/risk_guide.h) is added to the
//   tree through the ordinary extension, so that the first solution already
//   takes the right way around dense areas;
// - refinement: between iterations, random local edits of the best
//   trajectory (core/planners/path_refiner.h), accepted only when the exact risk of the
//   new pieces is lower, are written into the tree.
// Every reported risk stays the sum of exact piece risks: bit for bit what
// EvaluateTrajectory gives for the reported waypoints.
//
// Under binding flight limits (an endurance or a length limit, or MIN_TIME
// under a risk limit) the nodes also carry their flight time and length to
// the goal and the tree minimises risk + lambda * time, lambda adapted during
// the run (Run::SetLimits in core/planners/risk_rrt_star_run.h).
//
// Several missions to one goal share one such tree through
// core/planners/shared_goal_tree.h; this planner is its one-mission case.
#ifndef RISKPLAN_CORE_PLANNERS_RISK_RRT_STAR_H_
#define RISKPLAN_CORE_PLANNERS_RISK_RRT_STAR_H_

#include "core/planners/algorithm_entry.h"

namespace riskplan {

// RISK_RRT_STAR for MakePlanner and PlannerParams.
extern const AlgorithmEntry kRiskRrtStarEntry;

}  // namespace riskplan

#endif  // RISKPLAN_CORE_PLANNERS_RISK_RRT_STAR_H_
