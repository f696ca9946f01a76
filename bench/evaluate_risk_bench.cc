// Where EvaluateRisk's time goes, on one core: the README's 7.5 km trajectory
// across demo-city (3 waypoints, 1,502 samples), as riskplan-server evaluates
// it, and its stages alone:
//   BM_EvaluateRisk_Core    EvaluateTrajectory with RiskModel::Evaluate per
//                           sample (the server's path before issue 14 part 5)
//   BM_EvaluateRisk_Kernel  EvaluateTrajectory through accel's exact
//                           CpuRiskKernel (the default server's path now)
//   BM_Pieces               PiecesFromWaypoints alone
//   BM_Midpoints            sampling the pieces (PieceRisk) alone
//   BM_Checks               CheckConfiguration of every admissibility sample
//   BM_Risks_Core/_Kernel   the configuration risks of the midpoints alone
// The kernel path's answer is checked against the core path's bit for bit
// before anything is timed (the program aborts otherwise).
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <vector>

#include "accel/kernel_evaluator.h"
#include "accel/kernel_weights.h"
#include "accel/prepared_map.h"
#include "benchmark/benchmark.h"
#include "core/flight/piece_risk.h"
#include "core/flight/trajectory.h"
#include "core/map/demo_city.h"
#include "core/risk/risk_model.h"

namespace riskplan {
namespace {

const RiskModel& Model() {
  static const std::shared_ptr<const RiskModel> model = [] {
    auto map = MakeDemoCity();
    return *RiskModel::Create(*map, ModelParams{});
  }();
  return *model;
}

// scripts/server-bench.sh's WAYPOINTS.
const std::vector<Pose>& Waypoints() {
  static const std::vector<Pose> w = {
      {1200, 1500, 250, 0.785}, {4000, 4000, 250, 0.785}, {6800, 6500, 250, 0.785}};
  return w;
}

const std::vector<TrajectoryPiece>& Pieces() {
  static const std::vector<TrajectoryPiece> pieces =
      *PiecesFromWaypoints(Waypoints(), Model().params());
  return pieces;
}

const std::vector<Pose>& Midpoints() {
  static const std::vector<Pose> m = [] {
    std::vector<Pose> out;
    for (const TrajectoryPiece& p : Pieces())
      AppendMidpoints(p, Model().params().sample_step_m, &out);
    return out;
  }();
  return m;
}

bool Same(const ConfigurationRisk& a, const ConfigurationRisk& b) {
  return a.defined == b.defined && a.risk == b.risk && a.impact_factor == b.impact_factor &&
         a.expected_shelter == b.expected_shelter &&
         a.casualty_probability == b.casualty_probability && a.height_bin == b.height_bin &&
         a.heading_bin == b.heading_bin;
}

void CheckSame() {
  auto core = EvaluateTrajectory(Model(), Pieces(), {.keep_samples = true});
  auto fast = EvaluateTrajectory(Model(), Pieces(), {.keep_samples = true},
                                 &accel::ThreadKernelEvaluator());
  bool same = core.ok() && fast.ok() && core->risk == fast->risk &&
              core->admissible == fast->admissible &&
              core->samples.size() == fast->samples.size() &&
              core->first_violation.has_value() == fast->first_violation.has_value();
  for (size_t k = 0; same && k < core->samples.size(); ++k) {
    same = Same(core->samples[k].risk, fast->samples[k].risk);
  }
  if (!same) {
    std::fprintf(stderr, "the kernel path's evaluation differs from the core path's\n");
    std::abort();
  }
  std::fprintf(stderr, "%zu samples, risk %.17g, admissible %d\n", core->samples.size(), core->risk,
               core->admissible);
}

void BM_EvaluateRisk_Core(benchmark::State& state) {
  CheckSame();
  double sink = 0.0;
  for (auto _ : state) {
    auto pieces = PiecesFromWaypoints(Waypoints(), Model().params());
    sink += EvaluateTrajectory(Model(), *pieces)->risk;
  }
  benchmark::DoNotOptimize(sink);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_EvaluateRisk_Core);

void BM_EvaluateRisk_Kernel(benchmark::State& state) {
  double sink = 0.0;
  for (auto _ : state) {
    auto pieces = PiecesFromWaypoints(Waypoints(), Model().params());
    sink += EvaluateTrajectory(Model(), *pieces, {}, &accel::ThreadKernelEvaluator())->risk;
  }
  benchmark::DoNotOptimize(sink);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_EvaluateRisk_Kernel);

void BM_Pieces(benchmark::State& state) {
  for (auto _ : state) {
    auto pieces = PiecesFromWaypoints(Waypoints(), Model().params());
    benchmark::DoNotOptimize(pieces);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Pieces);

void BM_Midpoints(benchmark::State& state) {
  std::vector<Pose> out;
  for (auto _ : state) {
    out.clear();
    for (const TrajectoryPiece& p : Pieces()) {
      PieceRisk rule(p, Model().params().sample_step_m, Model().params());
      rule.AppendMidpoints(0, rule.parts(), &out);
    }
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Midpoints);

void BM_Checks(benchmark::State& state) {
  int bad = 0;
  for (auto _ : state) {
    for (const Pose& q : Midpoints()) {
      double limit = 0.0;
      bad += Model().CheckConfiguration(q, &limit) != ViolationKind::kNone;
    }
  }
  benchmark::DoNotOptimize(bad);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Checks);

void BM_Checks_GivenRisk(benchmark::State& state) {
  std::vector<ConfigurationRisk> risks(Midpoints().size());
  (void)accel::ThreadKernelEvaluator().EvaluateBatch(Model(), Midpoints(), risks);
  int bad = 0;
  for (auto _ : state) {
    for (size_t n = 0; n < risks.size(); ++n) {
      double limit = 0.0;
      bad += Model().CheckConfiguration(Midpoints()[n], risks[n], &limit) != ViolationKind::kNone;
    }
  }
  benchmark::DoNotOptimize(bad);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Checks_GivenRisk);

void BM_Risks_Core(benchmark::State& state) {
  std::vector<ConfigurationRisk> out(Midpoints().size());
  for (auto _ : state) {
    DirectRiskEvaluator direct;
    (void)direct.EvaluateBatch(Model(), Midpoints(), out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Risks_Core);

void BM_Risks_Kernel(benchmark::State& state) {
  std::vector<ConfigurationRisk> out(Midpoints().size());
  for (auto _ : state) {
    (void)accel::ThreadKernelEvaluator().EvaluateBatch(Model(), Midpoints(), out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Risks_Kernel);

// The kernel with the engine's caches but the site cache: the map's layers
// on 2 MiB pages (PreparedMap) and 64-byte-aligned weights.
void BM_Risks_KernelPrepared(benchmark::State& state) {
  static accel::PreparedMapCache maps(size_t{1} << 30);
  static accel::KernelWeightsCache weights(size_t{1} << 30);
  accel::CpuRiskKernel kernel(&maps, nullptr, {}, &weights);
  std::vector<ConfigurationRisk> out(Midpoints().size());
  for (auto _ : state) {
    kernel.Evaluate(Model(), Midpoints(), out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Risks_KernelPrepared);

}  // namespace
}  // namespace riskplan

BENCHMARK_MAIN();
