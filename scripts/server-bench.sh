#!/usr/bin/env bash
# Measures riskplan-server for docs/benchmarks.md: `riskplan load` against the
# no-op Ping ceiling in the same run, and the server's resident memory at idle
# (demo-city loaded) and with 16 plans running. Writes JSON reports and a
# summary into ${OUT_DIR:-out}/server-bench/. Assumes a built tree (scripts/build.sh).
#   DURATION_S  length of each load phase (default 10)
#   SKIP_LOAD=1 measure memory only
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BUILD_DIR:-build}/bin
OUT=${OUT_DIR:-out}/server-bench
DURATION_S=${DURATION_S:-10}
mkdir -p "$OUT"
WAYPOINTS="1200,1500,250,0.785; 4000,4000,250,0.785; 6800,6500,250,0.785"
START="1200,1500,250,0.785"
GOAL="6800,6500,250,0.785"

workdir=$(mktemp -d)
server_pid=""
stop_server() {
  if [ -n "$server_pid" ] && kill -0 "$server_pid" 2>/dev/null; then
    kill -TERM "$server_pid"; wait "$server_pid" || true
  fi
  server_pid=""
  exec 3<&- 2>/dev/null || true
}
trap 'stop_server; rm -rf "$workdir"' EXIT

# start_server FLAGS...: starts riskplan-server on 127.0.0.1:0, sets ADDRESS.
start_server() {
  rm -f "$workdir/ready"; mkfifo "$workdir/ready"
  "$BIN/riskplan-server" --listen=127.0.0.1:0 "$@" 2>"$OUT/server.log" >"$workdir/ready" &
  server_pid=$!
  exec 3<"$workdir/ready"
  read -r -t 120 line <&3
  ADDRESS=${line#riskplan-server listening on }
}
rss_mb() { awk '/^VmRSS/ {printf "%.1f", $2 / 1024}' "/proc/$server_pid/status"; }
hwm_mb() { awk '/^VmHWM/ {printf "%.1f", $2 / 1024}' "/proc/$server_pid/status"; }
load() { "$BIN/riskplan" --server="$ADDRESS" load --duration_s="$DURATION_S" "$@"; }

{
echo "# riskplan-server benchmark, $(date -u +%Y-%m-%dT%H:%MZ), $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg)"
start_server
"$BIN/riskplan" --server="$ADDRESS" maps >/dev/null
echo "idle RSS with demo-city loaded: $(rss_mb) MB (peak during start-up $(hwm_mb) MB)"

if [ -z "${SKIP_LOAD:-}" ]; then
echo; echo "## EvaluateRisk, closed loop, 4 callers, with the Ping ceiling"
load --rpc=eval --waypoints="$WAYPOINTS" --mode=closed --concurrency=4 --ceiling \
  --report_json="$OUT/eval-closed-4.json" | grep -v '^  t='
echo; echo "## EvaluateRisk of a 100 m polyline (20 samples), closed loop, 4 callers, with the Ping ceiling"
load --rpc=eval --polyline="1000,1000,250; 1100,1000,250" --mode=closed --concurrency=4 --ceiling \
  --report_json="$OUT/eval-short-closed-4.json" | grep -v '^  t='
echo; echo "## EvaluateRisk, closed loop, 16 callers, with the Ping ceiling"
load --rpc=eval --waypoints="$WAYPOINTS" --mode=closed --concurrency=16 --ceiling \
  --report_json="$OUT/eval-closed-16.json" | grep -v '^  t='
echo; echo "## EvaluateRisk, open loop, 500 calls/s, with the Ping ceiling"
load --rpc=eval --waypoints="$WAYPOINTS" --mode=open --rate=500 --ceiling \
  --report_json="$OUT/eval-open-500.json" | grep -v '^  t='
echo; echo "## EvaluateRisk, open loop, 1000 calls/s, with the Ping ceiling"
load --rpc=eval --waypoints="$WAYPOINTS" --mode=open --rate=1000 --ceiling \
  --report_json="$OUT/eval-open-1000.json" | grep -v '^  t='
echo; echo "## PlanTrajectory, closed loop, 2 callers, 500 ms budgets"
load --rpc=plan --start="$START" --goal="$GOAL" --budget_ms=500 --mode=closed --concurrency=2 \
  --ceiling --report_json="$OUT/plan-closed-2.json" | grep -v '^  t='
echo "RSS after the load runs: $(rss_mb) MB"
fi
stop_server

# sixteen_plans LABEL PLAN_FLAGS...: 16 plans at once on a fresh server; RSS
# sampled every second until they end.
sixteen_plans() {
  local label=$1; shift
  echo; echo "## Memory with 16 plans running ($label, --plan_threads=16)"
  start_server --plan_threads=16 --max_running_plans=16
  local idle peak now t=0
  idle=$(rss_mb); peak=$idle
  "$BIN/riskplan" --server="$ADDRESS" load --rpc=plan --start="$START" --goal="$GOAL" "$@" \
    --timeout_ms=900000 --mode=closed --concurrency=16 --duration_s=1 >/dev/null &
  local load_pid=$!
  while kill -0 "$load_pid" 2>/dev/null; do
    sleep 1; t=$((t + 1))
    now=$(rss_mb); peak=$(awk -v a="$peak" -v b="$now" 'BEGIN {print (b > a) ? b : a}')
    if [ $((t % 10)) -eq 0 ]; then echo "  t=${t}s RSS $now MB"; fi
  done
  wait "$load_pid"
  echo "idle $idle MB, peak with 16 plans $peak MB: $(awk -v a="$idle" -v b="$peak" \
    'BEGIN {printf "%.1f MB per plan", (b - a) / 16}')"
  echo "plans completed: $(grep -c '"method":"PlanTrajectory","code":"OK"' "$OUT/server.log" || true)," \
    "tree sizes (nodes): $(grep -o 'tree_size=[0-9]*' "$OUT/server.log" | cut -d= -f2 | sort -n \
    | sed -n '1p;$p' | paste -sd- - || true)"
  stop_server
}
sixteen_plans "30 s budgets" --budget_ms=30000
sixteen_plans "20000 iterations each" --budget_ms=0 --iterations=20000

echo; echo "## Memory of one plan alone (30 s budget, a full core)"
start_server
idle=$(rss_mb)
"$BIN/riskplan" --server="$ADDRESS" plan --start="$START" --goal="$GOAL" --budget_ms=30000 \
  --min_update_interval_ms=5000 | grep -E '^(ended|best):'
echo "idle $idle MB, peak $(hwm_mb) MB after one 30 s plan"
stop_server
} | tee "$OUT/summary.txt"
