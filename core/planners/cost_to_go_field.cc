#include "core/planners/cost_to_go_field.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "core/base/model_params.h"

namespace riskplan {

LatticeOptions GuideLatticeOptions(double spacing_m, double risk_step_m, int headings, int levels) {
  LatticeOptions o;
  o.spacing_m = spacing_m;
  o.headings = headings;
  o.level_offsets_m.clear();
  constexpr double kLowest = 5.0;
  constexpr double kHighest = 120.0;
  for (int k = 0; k < levels; ++k) {
    o.level_offsets_m.push_back(levels == 1 ? kLowest
                                            : kLowest + (kHighest - kLowest) * k / (levels - 1));
  }
  o.risk_step_m = risk_step_m;
  return o;
}

absl::StatusOr<std::unique_ptr<CostToGoField>> CostToGoField::Build(const RiskModel& model,
                                                                    const Pose& goal,
                                                                    const LatticeOptions& options,
                                                                    RiskEvaluator* evaluator,
                                                                    const StopCondition& stop) {
  absl::StatusOr<std::unique_ptr<StateLattice>> lattice = StateLattice::Create(model, options);
  if (!lattice.ok()) return lattice.status();
  std::unique_ptr<CostToGoField> f(new CostToGoField());
  f->lattice_ = std::move(*lattice);
  absl::StatusOr<LatticeField> field = f->lattice_->Field(goal, evaluator, stop, &f->stats_);
  if (!field.ok()) return field.status();
  f->field_ = std::move(*field);
  const StateLattice& g = *f->lattice_;
  const int per = g.states_per_position();
  f->least_by_position_.assign(g.position_count(), std::numeric_limits<double>::infinity());
  for (int64_t p = 0; p < g.position_count(); ++p) {
    for (int64_t s = p * per; s < (p + 1) * per; ++s) {
      if (g.valid(static_cast<int32_t>(s))) {
        f->least_by_position_[p] = std::min(f->least_by_position_[p], f->field_.cost[s]);
      }
    }
  }
  // Routes down the field read no edge memo.
  f->lattice_->DropMemo();
  return f;
}

absl::StatusOr<std::optional<LatticeRoute>> CostToGoField::Route(const RiskModel& model,
                                                                 const Pose& start,
                                                                 RiskEvaluator* evaluator) const {
  return lattice_->RouteDown(model, field_, start, evaluator);
}

double CostToGoField::LeastCostNear(double x, double y) const {
  const int64_t p = lattice_->PositionNear(x, y);
  return p < 0 ? std::numeric_limits<double>::infinity() : least_by_position_[p];
}

GuideFieldCache& GuideFieldCache::Default() {
  static auto* cache = new GuideFieldCache(Cache::Limits{size_t{256} << 20, 64});
  return *cache;
}

absl::StatusOr<std::shared_ptr<const CostToGoField>> GuideFieldCache::Get(
    const RiskModel& model, const Pose& goal, const LatticeOptions& options,
    RiskEvaluator* evaluator, const StopCondition& stop) {
  Key key;
  key.map = model.map_ptr().get();
  for (std::string_view name : ModelParamNames()) {
    absl::StatusOr<double> v = GetModelParam(model.params(), name);
    key.params.push_back(v.ok() ? *v : 0.0);
  }
  key.goal = {goal.x, goal.y, goal.z, goal.theta};
  key.lattice = {options.spacing_m, static_cast<double>(options.headings), options.risk_step_m,
                 options.level_offsets_m.empty() ? 0.0 : options.level_offsets_m[0],
                 static_cast<double>(options.level_offsets_m.size())};
  return cache_.GetOrBuild(
      key,
      [&]() -> absl::StatusOr<Cache::Built> {
        absl::StatusOr<std::unique_ptr<CostToGoField>> f =
            CostToGoField::Build(model, goal, options, evaluator, stop);
        if (!f.ok()) return f.status();
        const size_t bytes = (*f)->MemoryBytes();
        return Cache::Built{std::shared_ptr<const CostToGoField>(std::move(*f)), bytes};
      },
      model.map_ptr());
}

}  // namespace riskplan
