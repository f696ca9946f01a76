// CostToGoField: what a coarse state lattice (core/planners/state_lattice.h)
// learns about one goal, kept to guide RISK_RRT_STAR (its parameter
// `guide` = 1): every lattice state's risk to the goal and its next state.
// A start's route down the field is a few edge evaluations, so every mission
// to one goal (a shared goal tree's above all) gets a route that takes the
// right way around dense areas without a search of its own.
//
// The field depends on the map, the model's parameters (the wind among them),
// the goal and the lattice options, and on nothing else: GuideFieldCache keeps
// fields under that key, bounded by bytes and entries (core/base/
// bounded_cache.h), each entry stale once its map is freed. Its edge risks are
// sampled every `risk_step_m` (coarser than the model's step: a guide, not a
// reported risk); the planner inserts the route's waypoints through its
// ordinary extension, so every reported risk stays exact.
#ifndef RISKPLAN_CORE_PLANNERS_COST_TO_GO_FIELD_H_
#define RISKPLAN_CORE_PLANNERS_COST_TO_GO_FIELD_H_

#include <array>
#include <cstddef>
#include <memory>
#include <optional>
#include <tuple>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/bounded_cache.h"
#include "core/base/cancellation.h"
#include "core/planners/state_lattice.h"
#include "core/risk/risk_evaluator.h"
#include "core/risk/risk_model.h"

namespace riskplan {

// The lattice of a guide field: `spacing_m` apart, `headings` headings,
// `levels` altitude levels from 5 m to 120 m above the safe altitude evenly
// (one level: 5 m), edges sampled every risk_step_m.
LatticeOptions GuideLatticeOptions(double spacing_m, double risk_step_m, int headings = 8,
                                   int levels = 1);

class CostToGoField {
 public:
  // Builds the field of `goal` (admissible) under `model`. Errors from the
  // evaluator and the options, Cancelled once `stop` is reached.
  static absl::StatusOr<std::unique_ptr<CostToGoField>> Build(const RiskModel& model,
                                                              const Pose& goal,
                                                              const LatticeOptions& options,
                                                              RiskEvaluator* evaluator,
                                                              const StopCondition& stop = {});

  // The route from `start` down the field under `model` (one of the field's
  // map and parameters), nullopt when the field reaches the goal from none of
  // the states near the start. Thread-safe.
  absl::StatusOr<std::optional<LatticeRoute>> Route(const RiskModel& model, const Pose& start,
                                                    RiskEvaluator* evaluator) const;

  // The least cost-to-go of the states at the lattice position nearest
  // (x, y), over every heading and level: +inf off the map or where none
  // reaches the goal. A guide's figure (edge risks at risk_step_m), O(1).
  double LeastCostNear(double x, double y) const;

  const LatticeField& field() const { return field_; }
  const StateLattice& lattice() const { return *lattice_; }
  const LatticeSearchStats& build_stats() const { return stats_; }
  size_t MemoryBytes() const {
    return lattice_->MemoryBytes() + field_.MemoryBytes() +
           least_by_position_.capacity() * sizeof(double);
  }

 private:
  CostToGoField() = default;
  std::unique_ptr<StateLattice> lattice_;
  LatticeField field_;
  std::vector<double> least_by_position_;  // LeastCostNear's table
  LatticeSearchStats stats_;
};

// Fields by (map, model parameters, goal, lattice options).
class GuideFieldCache {
 public:
  struct Key {
    const void* map = nullptr;
    std::vector<double> params;  // every model parameter, in ModelParamNames order
    std::array<double, 4> goal{};
    std::array<double, 5> lattice{};  // spacing, headings, risk step, first level, levels
    bool operator<(const Key& o) const {
      return std::tie(map, params, goal, lattice) < std::tie(o.map, o.params, o.goal, o.lattice);
    }
  };
  using Cache = BoundedCache<Key, CostToGoField>;

  explicit GuideFieldCache(Cache::Limits limits) : cache_(limits) {}

  // The process's cache of RISK_RRT_STAR's guide fields: 256 MiB, 64 fields.
  static GuideFieldCache& Default();

  // The cached field, or one built now (and kept when it fits).
  absl::StatusOr<std::shared_ptr<const CostToGoField>> Get(const RiskModel& model, const Pose& goal,
                                                           const LatticeOptions& options,
                                                           RiskEvaluator* evaluator,
                                                           const StopCondition& stop = {});
  CacheStats stats() const { return cache_.stats(); }
  const Cache::Limits& limits() const { return cache_.limits(); }

 private:
  Cache cache_;
};

}  // namespace riskplan

#endif  // RISKPLAN_CORE_PLANNERS_COST_TO_GO_FIELD_H_
