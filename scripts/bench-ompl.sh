#!/usr/bin/env bash
# RISK_RRT_STAR against OMPL 1.5's RRT*, Informed RRT*, BIT* and ABIT* on
# demo-city (issues 7 and 14; docs/benchmarks.md, "Side by side with OMPL").
# Installs OMPL, the Boost libraries its CMake config links and
# python3-matplotlib, builds only riskplan-bench-ompl, checks the adapter
# against EvaluateTrajectory (including risk model version 2's
# IMPACT_OUTSIDE_MAP by the map's edges), runs the benchmark (one process per
# planner, scenario and seed, one at a time) and writes the report, the
# tables (with the per-scenario verdict on the target: the best OMPL
# planner's 3-second median reached within 0.05 s, and at least 20 % lower at
# 3 s) and the plot into ${OUT_DIR:-out}/ompl-bench/.
#
#   bash scripts/bench-ompl.sh [smoke|full]      (default: full)
#
# smoke: one scenario, two seeds, 1 s (about half a minute).
# full:  ten scenarios x 10 seeds x 5 planners x 3 s, plus RISK_RRT_STAR's
#        runs with the smaller budgets (about 30 minutes).
# ABIT* runs with BIT*'s tuned settings (samples per batch, rewire factor,
# k-nearest) and OMPL's defaults for its own three (inflation, truncation).
# Variables: BUILD_DIR (default build), RISKPLAN_JOBS (compile jobs, default
# 1), SEEDS, BENCH_FLAGS (extra flags for riskplan-bench-ompl), PYTHON
# (default /usr/bin/python3, which Debian's python3-matplotlib serves).
# Benchmarks are measurements: run this on a machine that is otherwise quiet,
# and quote the load it had (the report records `uptime` before and after,
# and the 1-minute load average before each scenario and seed).
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:-full}
bash scripts/install-deps.sh libompl-dev libboost-serialization-dev \
  libboost-filesystem-dev libboost-system-dev python3-matplotlib
BUILD_DIR=${BUILD_DIR:-build}
cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DRISKPLAN_BUILD_BENCH=ON >/dev/null
ninja -C "$BUILD_DIR" -j "${RISKPLAN_JOBS:-1}" riskplan-bench-ompl
BIN=$BUILD_DIR/bin/riskplan-bench-ompl
OUT=${OUT_DIR:-out}/ompl-bench
mkdir -p "$OUT"

"$BIN" --self_check

# The tuned OMPL settings (docs/benchmarks.md says how they were chosen); the
# bit_* ones apply to BIT* and ABIT* alike.
TUNED=(--rrt_k_nearest=false --rrt_rewire_factor=16 --rrt_range_m=1200 --rrt_nn=grid
       --irrt_admissible_cost_to_come=false --bit_samples=200 --bit_rewire_factor=1.1
       --bit_k_nearest=true)
case "$mode" in
  smoke) ARGS=(--scenarios=5km-a --seeds="${SEEDS:-2}" --budget_s=1 --checkpoints=0.1,0.3,1) ;;
  full) ARGS=(--seeds="${SEEDS:-10}" --budget_s=3 --checkpoints=0.1,0.3,1,3) ;;
  *) echo "usage: $0 [smoke|full]" >&2; exit 2 ;;
esac
report=$OUT/$mode.csv
{
  echo "# uptime before: $(uptime)"
  echo "# command: $BIN ${TUNED[*]} ${ARGS[*]} ${BENCH_FLAGS:-}"
  # shellcheck disable=SC2086
  "$BIN" "${TUNED[@]}" "${ARGS[@]}" ${BENCH_FLAGS:-} 2>"$OUT/$mode.stderr.log"
  echo "# uptime after: $(uptime)"
} >"$report"
budgets=0.1,0.3,1,3
[ "$mode" = smoke ] && budgets=0.1,0.3,1
# Debian's interpreter: python3-matplotlib is installed for it (a python3
# earlier in PATH, e.g. pyenv's, would not see it).
"${PYTHON:-/usr/bin/python3}" bench/ompl/plot_ompl_bench.py "$report" --budgets="$budgets" \
  --png "$OUT/$mode.png" --title "riskplan vs OMPL 1.5.2 on demo-city ($mode)" \
  | tee "$OUT/$mode.md"
