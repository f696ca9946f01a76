#!/usr/bin/env bash
# The README's demo under limits (issue 35), measured on demo-city: the
# endurance of 600 s against the best of five plans with the same limit, an
# endurance of 200 s that no route meets, MIN_TIME under a per-flight risk
# limit of twice the MIN_RISK plan's risk, the per-hour target, and the front
# after 3 s checked against dedicated plans with each point's flight time as
# the endurance. Prints the lines docs/benchmarks.md ("Limits on the demo")
# quotes. Assumes build/bin/riskplan and riskplan-server are built.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/lib.sh
BIN=${BUILD_DIR:-build}/bin
START="1200,1500,250,0.785"
GOAL="6800,6500,250,0.785"
start_demo_server ""
plan() {
  "$BIN/riskplan" --server="$ADDRESS" plan --map=demo-city --start="$START" --goal="$GOAL" \
    --min_update_interval_ms=1000 "$@" | grep -E "^(ended|best|flight time|limit|front|no traj|risk per)" || true
}
risk_of() { grep -oP '^best: risk \K[0-9.e+-]+' <<<"$1"; }

echo "== MIN_RISK, no limit, 10 s =="
free=$(plan --budget_ms=10000)
echo "$free"
echo
for seed in 1 2 3 4 5; do
  echo "== MIN_RISK, --max_flight_time_s=600, 10 s, seed $seed =="
  plan --budget_ms=10000 --max_flight_time_s=600 --seed=$seed
done
echo
echo "== --max_flight_time_s=200, 10 s =="
plan --budget_ms=10000 --max_flight_time_s=200
echo
limit=$(python3 -c "print(2 * $(risk_of "$free"))")
echo "== MIN_TIME, --max_risk=$limit (twice the MIN_RISK plan's), 10 s =="
plan --budget_ms=10000 --objective=MIN_TIME --max_risk="$limit"
echo
echo "== MIN_RISK, --max_risk_per_flight_hour=1e-6, 10 s =="
plan --budget_ms=10000 --max_risk_per_flight_hour=1e-6
echo "== MIN_TIME, --max_risk_per_flight_hour=1e-6, 10 s =="
plan --budget_ms=10000 --objective=MIN_TIME --max_risk_per_flight_hour=1e-6
echo "== MIN_TIME, --max_risk_per_flight_hour=2e-6, 10 s =="
plan --budget_ms=10000 --objective=MIN_TIME --max_risk_per_flight_hour=2e-6
echo "== MIN_RISK, --max_risk_per_flight_hour=2e-6, 10 s =="
plan --budget_ms=10000 --max_risk_per_flight_hour=2e-6
echo
echo "== the front after 3 s (--pareto) =="
front=$(plan --budget_ms=3000 --pareto)
echo "$front"
# Three points of the front (the quickest, the middle one, the safest):
# a dedicated 3-s plan with that point's flight time as the endurance.
times=$(grep -oP '^front: .*' <<<"$front" | grep -oP '\(\K[0-9.]+(?=, )' || true)
n=$(wc -w <<<"$times")
if [ "$n" -ge 3 ]; then
  for i in 1 $(( (n + 1) / 2 )) "$n"; do
    t=$(awk -v i="$i" '{print $i}' <<<"$(tr '\n' ' ' <<<"$times")")
    echo "== dedicated 3-s plan, --max_flight_time_s=$t (front point $i of $n) =="
    plan --budget_ms=3000 --max_flight_time_s="$t"
  done
fi
