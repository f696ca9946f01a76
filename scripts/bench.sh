#!/usr/bin/env bash
# Runs riskplan's benchmark programs and prints their reports. Results and the
# commands that produced them are recorded in docs/benchmarks.md.
#
#   bash scripts/bench.sh [planner|shared|wind|kernel|rtl|all]   (default: all)
#
# Benchmarks are measurements, not tests: run them on a quiet machine and quote
# medians. Extra variables: SEEDS (planner seeds, default 5), BUDGET_S (3).
set -euo pipefail
cd "$(dirname "$0")/.."
what=${1:-all}
if [ "$what" = rtl ] || [ "$what" = all ]; then
  bash scripts/install-deps.sh verilator
  bash scripts/build.sh -DRISKPLAN_BUILD_BENCH=ON -DRISKPLAN_WITH_VERILATOR=ON >&2
else
  bash scripts/build.sh -DRISKPLAN_BUILD_BENCH=ON >&2
fi
BIN=${BUILD_DIR:-build}/bin
if [ "$what" = kernel ] || [ "$what" = all ]; then
  echo "== configuration-risk kernel (bench/risk_kernel_bench.cc) =="
  "$BIN/riskplan-bench-risk" --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
fi
if [ "$what" = planner ] || [ "$what" = all ]; then
  echo "== RISK_RRT_STAR on the demo-city scenarios (bench/planner_bench.cc) =="
  "$BIN/riskplan-bench-planner" --seeds="${SEEDS:-5}" --budget_s="${BUDGET_S:-3}"
fi
if [ "$what" = shared ] || [ "$what" = all ]; then
  echo "== 32 missions to one depot: shared goal tree vs separate plans (bench/shared_tree_bench.cc) =="
  "$BIN/riskplan-bench-shared-tree"
  echo "== the same from one area: 32 starts within 1.2 km of (2000, 6000) =="
  "$BIN/riskplan-bench-shared-tree" --start_area=2000,6000,1200
fi
if [ "$what" = wind ] || [ "$what" = all ]; then
  echo "== planning in a wind: node rate, a new wind's model, wind-blind plans (bench/wind_bench.cc) =="
  "$BIN/riskplan-bench-wind" --seeds="${SEEDS:-3}" --budget_s=2
fi
if [ "$what" = rtl ] || [ "$what" = all ]; then
  echo "== the component's RTL under Verilator: cycles by lane count (bench/rtl_bench.cc) =="
  "$BIN/riskplan-bench-rtl" --configs=4096
  "$BIN/riskplan-bench-rtl" --configs=4096 --config=l8-board --lanes=1,8
fi
