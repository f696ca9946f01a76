// Run::GuideByField: RISK_RRT_STAR's seeding from the goal's cost-to-go field
// (parameter `guide` = 1; core/planners/cost_to_go_field.h).
#include <chrono>
#include <optional>
#include <vector>

#include "core/planners/cost_to_go_field.h"
#include "core/planners/risk_rrt_star_run.h"

namespace riskplan::rrt_star {

absl::Status Run::GuideByField(size_t m) {
  if (field_unavailable_) return absl::OkStatus();
  if (field_ == nullptr) {
    // A field not cached yet is built in at most half of the time left to
    // the earliest deadline, so that a short budget still plans: a build cut
    // short there is given up for this run (and not cached), and the run goes
    // on without the field. Without a deadline (an iteration budget) the
    // build runs to its end, so the run stays deterministic.
    const std::optional<std::chrono::steady_clock::time_point> earliest = EarliestDeadline();
    std::optional<std::chrono::steady_clock::time_point> build_deadline;
    if (earliest.has_value()) {
      const auto now = std::chrono::steady_clock::now();
      build_deadline = now + (*earliest - now) / 2;
    }
    absl::StatusOr<std::shared_ptr<const CostToGoField>> field = GuideFieldCache::Default().Get(
        model_, goal_,
        GuideLatticeOptions(params_.guide_field_m, params_.guide_field_step_m,
                            params_.guide_field_headings, params_.guide_field_levels),
        evaluator_, StopCondition(&cancel_, nullptr, build_deadline));
    if (!field.ok()) {
      if (!absl::IsCancelled(field.status())) return field.status();
      // Cut short by the run's own token: as an iteration the budget would
      // not have begun. By the build's share of the budget: no field.
      if (stop_.Reached()) return RunStopped();
      field_unavailable_ = true;
      return absl::OkStatus();
    }
    field_ = std::move(*field);
  }
  absl::StatusOr<std::optional<LatticeRoute>> route =
      field_->Route(model_, missions_[m].spec.start, evaluator_);
  if (!route.ok()) return route.status();
  if (!route->has_value()) return absl::OkStatus();
  missions_[m].field_route_risk = (*route)->risk;
  // The lattice states between start and goal, from the goal's side, through
  // the ordinary extension (exact risks, exact admissibility).
  const std::vector<Pose>& w = (*route)->waypoints;
  for (size_t k = w.size() - 1; k-- > 1;) {
    if (!Admissible(w[k])) continue;
    if (absl::Status s = Extend(w[k]); !s.ok()) return s;
  }
  if (absl::Status s = ConnectStart(m); !s.ok()) return s;
  MaybeReport();
  return absl::OkStatus();
}

}  // namespace riskplan::rrt_star
