#!/usr/bin/env bash
# The README's "Flying in wind" demo: the README's demo plan (run-demo.sh's
# start and goal across demo-city) planned in still air and in a wind of
# WIND (8 m/s from the west by default), both drawn in one picture
# (docs/img/wind-demo.svg: two routes, a key, the wind's arrow), then each
# route's risk evaluated in both conditions: the table of the README.
# The plans have an iteration budget (and a seed), so a run gives the same
# routes and numbers on any machine. Exits non-zero when any step fails.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/lib.sh
# NO_BUILD=1: use the programs already in $BUILD_DIR/bin (riskplan-server, riskplan).
[ -n "${NO_BUILD:-}" ] || bash scripts/build.sh >&2
BIN=${BUILD_DIR:-build}/bin
OUT=${OUT_DIR:-out}
PICTURE=${PICTURE:-docs/img/wind-demo.svg}
mkdir -p "$OUT" "$(dirname "$PICTURE")"

START=${START:-"1200,1500,250,0.785"}
GOAL=${GOAL:-"6800,6500,250,0.785"}
WIND=${WIND:-"8@270"}
ITERATIONS=${ITERATIONS:-2000}
SEED=${SEED:-1}

start_demo_server "$OUT/wind-demo-server.log"
rp() { "$BIN/riskplan" --server="$ADDRESS" "$@"; }

# Two missions of one fleet: the same start, goal, seed and budget, one in
# still air and one in the wind.
cat > "$WORKDIR/missions.json" <<JSON
{"missions": [
  {"id": "still-air", "start": "$START"},
  {"id": "wind-${WIND/@/-from-}", "start": "$START", "wind": "$WIND"}]}
JSON
echo "== the demo plan in still air and in a wind of ${WIND%@*} m/s from ${WIND#*@} deg =="
rp fleet --map=demo-city --missions="$WORKDIR/missions.json" --goal="$GOAL" \
  --budget_ms=0 --iterations="$ITERATIONS" --seed="$SEED" \
  --picture="$PICTURE" --trajectory_out="$OUT/wind-demo.json"

# Each route's risk in each condition (riskplan eval of its waypoints).
risk_of() {  # FILE [--wind=...] -> "risk flight_time_s"
  rp eval --map=demo-city --trajectory_file="$1" --json "${@:2}" |
    python3 -c 'import json,sys; r=json.load(sys.stdin); print("%.4g %.1f %s" % (r["risk"], r.get("flight_time_s", 0), "admissible" if r.get("admissible") else "NOT admissible"))'
}
echo
echo "== each route evaluated in both conditions =="
printf '| plan \\ evaluated in | still air | wind %s m/s from %s° |\n' "${WIND%@*}" "${WIND#*@}"
printf '|---|---|---|\n'
for id in still-air "wind-${WIND/@/-from-}"; do
  file="$OUT/wind-demo-$id.json"
  read -r still_risk still_time still_ok <<<"$(risk_of "$file")"
  read -r wind_risk wind_time wind_ok <<<"$(risk_of "$file" --wind="$WIND")"
  printf '| planned in %s | %s (%s s%s) | %s (%s s%s) |\n' "$id" \
    "$still_risk" "$still_time" "$([ "$still_ok" = admissible ] && echo "" || echo ", not admissible")" \
    "$wind_risk" "$wind_time" "$([ "$wind_ok" = admissible ] && echo "" || echo ", not admissible")"
done

stop_demo_server
echo
echo "picture: $PICTURE (the two routes with a key, the wind's arrow top right)"
