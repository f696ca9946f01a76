// Run::GuideByField: RISK_RRT_STAR's seeding from the goal's cost-to-go field
// (parameter `guide` = 1; core/planners/cost_to_go_field.h).
#include <vector>

#include "core/planners/cost_to_go_field.h"
#include "core/planners/risk_rrt_star_run.h"

namespace riskplan::rrt_star {

absl::Status Run::GuideByField(size_t m) {
  if (field_ == nullptr) {
    absl::StatusOr<std::shared_ptr<const CostToGoField>> field = GuideFieldCache::Default().Get(
        model_, goal_, GuideLatticeOptions(params_.guide_field_m, params_.guide_field_step_m),
        evaluator_, stop_);
    if (!field.ok()) {
      // A build cut short by the run's own budget or token: as an iteration
      // the budget would not have begun.
      if (absl::IsCancelled(field.status()) && stop_.Reached()) return RunStopped();
      return field.status();
    }
    field_ = std::move(*field);
  }
  absl::StatusOr<std::optional<LatticeRoute>> route =
      field_->Route(model_, missions_[m].spec.start, evaluator_);
  if (!route.ok()) return route.status();
  if (!route->has_value()) return absl::OkStatus();
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
