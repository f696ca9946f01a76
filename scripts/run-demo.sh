#!/usr/bin/env bash
# The README's main job: builds riskplan if needed, starts riskplan-server on
# the built-in demo-city (127.0.0.1, a free port), plans a trajectory across
# the city with the `riskplan` client while showing each streamed improvement,
# writes a picture of the plan (out/demo-plan.svg), and stops the server.
# Exits non-zero when any step fails. Extra arguments go to `riskplan plan`
# (e.g. --budget_ms=20000 --tree --picture=out/plan.png).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/lib.sh
bash scripts/build.sh >&2
BIN=${BUILD_DIR:-build}/bin
OUT=${OUT_DIR:-out}
mkdir -p "$OUT"

# South-west suburbs to north-east suburbs at 250 m AMSL (both admissible:
# inside the 30-150 m AGL band and above the emergency-glide altitude).
START=${START:-"1200,1500,250,0.785"}
GOAL=${GOAL:-"6800,6500,250,0.785"}
BUDGET_MS=${BUDGET_MS:-10000}

start_demo_server "$OUT/demo-server.log"
echo "== riskplan-server on demo-city at $ADDRESS =="
"$BIN/riskplan" --server="$ADDRESS" maps

echo
echo "== riskplan plan: streamed improvements =="
"$BIN/riskplan" --server="$ADDRESS" plan --map=demo-city \
  --start="$START" --goal="$GOAL" --budget_ms="$BUDGET_MS" --min_update_interval_ms=250 \
  --picture="$OUT/demo-plan.svg" --trajectory_out="$OUT/demo-plan.json" "$@"

echo
echo "== riskplan eval of the planned trajectory (same server, same risk) =="
evaluation=$("$BIN/riskplan" --server="$ADDRESS" eval --map=demo-city \
  --trajectory_file="$OUT/demo-plan.json")
echo "${evaluation%%$'\n'*}"

stop_demo_server
echo
echo "picture: $OUT/demo-plan.svg (population density, no-fly zones in violet, landing sites,"
echo "         every streamed improvement from light to dark blue, start green, goal magenta)"
