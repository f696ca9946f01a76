#!/usr/bin/env bash
# Soak and chaos run of riskplan-server (docs/reliability-soak.md).
#
#   bash scripts/soak.sh DURATION        DURATION: 60s, 30m, 1h or seconds (>= 20)
#
# Assumes a built tree (scripts/build.sh). What it does:
#  1. Starts two riskplan-fpga-shims (model device, the board's number format),
#     the soak server on demo-city with 2 CPU workers and both shims, and a
#     CPU-only reference server (no engine: every risk on the exact CPU path);
#     the reference answers the fixed trajectories below, then stops. One
#     round of checks on the soak server builds the overridden parameters'
#     model and uploads every blob to both boards.
#  2. Measures the maximum of the mix on the soak server, briefly (5 s; 15 s
#     for runs of 5 minutes or more): the four generators below at once in
#     closed loop, 4 callers for the long EvaluateRisk and 2 for each other
#     RPC, which saturates two cores; each RPC's calls/s is its share.
#  3. For DURATION, offers 80 % of each share in open loop (`riskplan load`,
#     a fixed arrival rate): EvaluateRisk of a long trajectory (cut into
#     chunks that the boards take) and of a short one, PlanTrajectory with
#     300 ms budgets, Ping. At most 64 calls of a generator in flight (4
#     plans): on a machine shared with other jobs the capacity can shrink at
#     any time, and an unbounded open loop would then pile up calls (memory,
#     queues, deadlines) that say nothing about leaks; a call due beyond the
#     bound is not sent and counts as CLIENT_OVERLOADED. Meanwhile:
#     - chaos: every KILL_PERIOD (60 s; DURATION / 4, at least 10 s, for runs
#       under 4 minutes: 15 s, four kills, in a 60 s run) SIGKILL shim A and
#       restart it on the same port; half a period later SIGSTOP shim B for
#       1-5 s (longer than an EVAL's 2 s deadline, sometimes), then SIGCONT;
#       every KILL_PERIOD / 6 a plan (random seed and endpoints, 5 s budget)
#       that is cancelled, alternately by a deadline of 50-800 ms and by
#       SIGKILLing its client after 0.1-2 s;
#     - a checker asks the soak server for the fixed trajectories' risks,
#       with every sample, every CHECK_PERIOD (10 s; DURATION / 20, at least
#       2 s, for runs under 5 minutes);
#     - a sampler reads the server's VmRSS and Threads (/proc/PID/status), its
#       open descriptors (/proc/PID/fd) and two metrics every SAMPLE_PERIOD
#       (10 s; DURATION / 30, at least 1 s, for runs under 5 minutes).
#  4. Stops the chaos, waits for both shims' workers to be up again and for no
#     plan to run, reads the metrics, stops the server with SIGTERM.
#  5. Judges (scripts/soak_report.py), prints the summary, writes
#     ${OUT_DIR:-out}/soak/summary.txt, samples.csv, events.csv and soak.png,
#     and exits 1 naming every check that failed.
#
# The checks (the thresholds are about leaks, hangs and wrong answers, not
# speed, so that a loaded 2-core machine passes them):
#  rss      after warm-up, no RSS sample more than 5 % above the median of
#           the first quarter of the post-warm-up samples (growth: what a
#           leak does). A fall is reported, not judged: glibc gives a
#           per-thread arena's free top back to the system when it likes (a
#           60 s run under stress-ng fell by 49 MB, 9 %, mid-run).
#           Warm-up: the measurement phase (at saturation: the caches, the
#           overridden parameters' model and the boards' blobs are all in
#           place at its end) plus the first 20 % of DURATION, at least 30 s
#           and at most 2 minutes. The RSS still steps up during the first
#           tens of seconds of load and chaos, by up to 8 % in the 60 s runs
#           measured here: glibc's per-thread arenas keep the high-water mark
#           of what each thread allocated at once (model builds, blob
#           uploads, plans), which rises while the mix of work reaches every
#           thread. So a 60 s run judges its last 30 s (about 15 samples) and
#           fails only a fast leak (a few tens of MB in 30 s); the 30-minute
#           run, with 28 minutes judged, is the one that bounds slow leaks.
#  fds, threads  flat after warm-up: every sample within the post-warm-up
#           median +- 16 descriptors (client connections, the checker's and
#           the chaos's clients and the shims' reconnections come and go) and
#           +- 8 threads, and the median of the last quarter of the samples at
#           most 4 above that of the first (no creeping).
#  errors   every call of the load generators and of the checker OK. Their
#           deadlines are 60 s, far beyond any latency at 80 %, so a
#           DEADLINE_EXCEEDED is a hang, not slowness; CLIENT_OVERLOADED (calls
#           never sent, above) is reported, not judged. The documented errors
#           are only those the chaos causes on purpose: DEADLINE_EXCEEDED for
#           the plans given a deadline shorter than their budget, CANCELLED
#           for the plans whose client was killed (the server's
#           riskplan_rpcs_total may count either for either; their sum must
#           not exceed the number of such plans). A killed or stopped shim
#           must cost no call anything but time (docs/accel.md: a chunk a
#           board fails goes back to the queue, after two board failures to
#           the CPU, which is always there): no UNAVAILABLE, no
#           DEADLINE_EXCEEDED, no RESOURCE_EXHAUSTED, no INTERNAL, nothing.
#  results  every checked answer equal to the CPU-only server's: lengths,
#           poses, pieces, admissibility and violations bit for bit; risks
#           bit for bit where the CPU computed them (all of the short
#           trajectory: one chunk, always on the calling thread) and, for a
#           sample a board computed, within the board format's 1e-5 relative
#           (docs/accel.md: a chunk from a board carries its fixed-point
#           rounding, so bit-identity is not what the server promises
#           there); a piece's or trajectory's risk bit for bit when all its
#           samples are.
#  chaos    at least one shim kill, shim stop and cancelled plan of each kind
#           happened, every restart succeeded, both boards evaluated
#           configurations and failed no spot check.
#  recovery after the chaos both workers up again and no plan running within
#           60 s; the server drains and exits 0 on SIGTERM; no load generator
#           still running 120 s after the end.
#
# Variables: BUILD_DIR (default build), OUT_DIR (default out), SOAK_SEED
# (chaos randomness, default the time), SOAK_INSTALL=0 (do not install
# python3-matplotlib: without it the plot is skipped, the checks still run),
# PYTHON (default /usr/bin/python3, Debian's, which python3-matplotlib serves).
set -euo pipefail
export LC_ALL=C
cd "$(dirname "$0")/.."
ROOT=$PWD

usage() { echo "usage: $0 DURATION   (e.g. 60s, 30m, 1h, or seconds)" >&2; exit 2; }
[ $# -eq 1 ] || usage
case "$1" in
  *[0-9]s) D=${1%s} ;;
  *[0-9]m) D=$(( ${1%m} * 60 )) ;;
  *[0-9]h) D=$(( ${1%h} * 3600 )) ;;
  *) D=$1 ;;
esac
[[ "$D" =~ ^[0-9]+$ ]] && [ "$D" -ge 20 ] || { echo "soak: DURATION must be at least 20 s" >&2; usage; }

PYTHON=${PYTHON:-/usr/bin/python3}
if [ "${SOAK_INSTALL:-1}" != 0 ]; then bash scripts/install-deps.sh python3-matplotlib; fi
abs() { case "$1" in /*) echo "$1" ;; *) echo "$ROOT/$1" ;; esac; }
BIN=$(abs "${BUILD_DIR:-build}")/bin
OUT=$(abs "${OUT_DIR:-out}")/soak
for p in riskplan-server riskplan riskplan-fpga-shim; do
  [ -x "$BIN/$p" ] || { echo "soak: $BIN/$p missing: build first (scripts/build.sh)" >&2; exit 1; }
done
mkdir -p "$OUT"
rm -rf "$OUT"/*.json "$OUT"/*.log "$OUT"/*.csv "$OUT"/*.txt "$OUT"/soak.png "$OUT"/wrong
work=$(mktemp -d)
mkdir -p "$work/checks" "$work/chaos"

# Periods, scaled for short runs (see above).
if [ "$D" -ge 300 ]; then SAMPLE_MS=10000; else SAMPLE_MS=$(( D * 1000 / 30 )); fi
[ "$SAMPLE_MS" -ge 1000 ] || SAMPLE_MS=1000
KILL_MS=$(( D * 1000 / 4 ))
[ "$KILL_MS" -le 60000 ] || KILL_MS=60000
[ "$KILL_MS" -ge 10000 ] || KILL_MS=10000
CANCEL_MS=$(( KILL_MS / 6 ))
if [ "$D" -ge 300 ]; then CHECK_MS=10000; else CHECK_MS=$(( D * 1000 / 20 )); fi
[ "$CHECK_MS" -ge 2000 ] || CHECK_MS=2000
if [ "$D" -ge 300 ]; then MEASURE_S=15; else MEASURE_S=5; fi
PLAN_THREADS=2
PLAN_BUDGET_MS=300
SEED=${SOAK_SEED:-$(date +%s)}
RANDOM=$SEED

# The fixed trajectories of the load and of the result checks (all on
# demo-city, default model parameters unless said): a short polyline (200
# samples: one chunk, always computed on the calling thread's CPU), two long
# ones (1502 and 2100 samples: cut into chunks that boards take) and a long
# one with overridden parameters (another risk model and impact table: the
# model cache and a second kernel upload to the boards).
SHORT_POLYLINE="1000,1000,250; 2000,1000,250"
LONG_WAYPOINTS="1200,1500,250,0.785; 4000,4000,250,0.785; 6800,6500,250,0.785"
CHECKS=(
  "short|--polyline=$SHORT_POLYLINE"
  "long-waypoints|--waypoints=$LONG_WAYPOINTS"
  "long-polyline|--polyline=1000,6000,300; 7000,6000,300; 7000,1500,300"
  "long-params|--waypoints=1200,1500,250,0.785; 6800,6500,250,0.785|--params=mass_kg=3,airspeed_mps=14"
)
# Plan endpoints, each admissible (scripts/run-demo.sh's start and goal first).
POSES=("1200,1500,250,0.785" "6800,6500,250,0.785" "1500,6500,350,-0.785" "1000,4000,250,0"
       "7000,4000,250,3.14" "4000,1000,250,1.57")

now_ms() { local t=${EPOCHREALTIME/./}; echo $(( t / 1000 )); }
T0=$(now_ms)
rel_s() { local t; t=$(now_ms); awk -v a="$t" -v b="$T0" 'BEGIN {printf "%.1f", (a - b) / 1000}'; }
log() { echo "[soak $(rel_s)s] $*"; }
event() { echo "$(rel_s),$1,$2" >>"$OUT/events.csv"; }

pids=()
cleanup() {
  set +e
  touch "$work/stop"
  for f in "$work"/shim_*.pid; do [ -f "$f" ] && kill -CONT "$(cat "$f")" 2>/dev/null; done
  for p in "${pids[@]}"; do kill -KILL "$p" 2>/dev/null; done
  for f in "$work"/shim_*.pid "$work"/*.server.pid; do [ -f "$f" ] && kill -KILL "$(cat "$f")" 2>/dev/null; done
  wait 2>/dev/null
  rm -rf "$work"
}
trap cleanup EXIT

# spawn NAME CMD...: runs CMD in the background, a child of this shell
# (stdout in the work directory, stderr appended to $OUT/NAME.log); its pid
# goes to $work/NAME.pid.
spawn() {
  local name=$1; shift
  : >"$work/$name.out"
  "$@" >"$work/$name.out" 2>>"$OUT/$name.log" &
  echo $! >"$work/$name.pid"
}
# ready NAME PREFIX: waits (up to 120 s) for NAME's readiness line "PREFIX
# HOST:PORT" and prints HOST:PORT; fails if NAME exits first.
ready() {
  local name=$1 prefix=$2 line pid
  pid=$(cat "$work/$name.pid")
  for _ in $(seq 1 1200); do
    line=$(grep -m1 "^$prefix" "$work/$name.out" || true)
    [ -n "$line" ] && { echo "${line#"$prefix"}"; return 0; }
    kill -0 "$pid" 2>/dev/null || return 1
    sleep 0.1
  done
  return 1
}
start_shim() {  # start_shim NAME [PORT]: prints HOST:PORT once it listens
  spawn "shim_$1" "$BIN/riskplan-fpga-shim" --listen="127.0.0.1:${2:-0}" --device=model --format=board
  disown  # killed on purpose: no job report from the shell
  ready "shim_$1" "riskplan-fpga-shim listening on "
}
# The metrics page (HTTP/1.0 through bash's /dev/tcp: no curl needed), or
# nothing within 5 s.
metrics() {
  timeout 5 bash -c 'exec 5<>"/dev/tcp/${1%:*}/${1##*:}" &&
    printf "GET /metrics HTTP/1.0\r\nHost: %s\r\n\r\n" "$1" >&5 && cat <&5' _ "$METRICS" \
    2>/dev/null | tr -d '\r' || true
}
metric() {  # metric SERIES: its value in the last scrape ($work/metrics.txt), or empty
  awk -v s="$1" '$1 == s {print $2}' "$work/metrics.txt"
}
scrape() { metrics >"$work/metrics.txt"; }

echo "soak: $D s, seed $SEED, samples every $((SAMPLE_MS / 1000)) s, shim kill every" \
  "$((KILL_MS / 1000)) s, cancelled plan every $((CANCEL_MS / 1000)).$((CANCEL_MS % 1000 / 100)) s," \
  "checks every $((CHECK_MS / 1000)) s; $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg)"
echo "t_s,kind,detail" >"$OUT/events.csv"

# --- 1. shims, soak server, reference server -------------------------------
# Started here, not in a command substitution: they stay this shell's children.
spawn shim_a "$BIN/riskplan-fpga-shim" --listen=127.0.0.1:0 --device=model --format=board
spawn shim_b "$BIN/riskplan-fpga-shim" --listen=127.0.0.1:0 --device=model --format=board
disown -a  # the shims are killed on purpose: no job reports from the shell
SHIM_A=$(ready shim_a "riskplan-fpga-shim listening on ") || { echo "soak: shim A did not start" >&2; exit 1; }
SHIM_B=$(ready shim_b "riskplan-fpga-shim listening on ") || { echo "soak: shim B did not start" >&2; exit 1; }
log "shims at $SHIM_A (killed) and $SHIM_B (stopped)"
# Both servers load demo-city at once (about 15 s each on two cores).
spawn soak.server "$BIN/riskplan-server" --listen=127.0.0.1:0 --cpu_workers=2 \
  --fpga_shims="$SHIM_A,$SHIM_B" --metrics_listen=127.0.0.1:0 --rpc_log=false \
  --plan_threads=$PLAN_THREADS --max_running_plans=16
spawn reference.server "$BIN/riskplan-server" --listen=127.0.0.1:0 --rpc_log=false
SERVER=$(ready soak.server "riskplan-server listening on ") || {
  echo "soak: the soak server did not start; its log:" >&2; cat "$OUT/soak.server.log" >&2; exit 1; }
REF=$(ready reference.server "riskplan-server listening on ") || {
  echo "soak: the reference server did not start; its log:" >&2; cat "$OUT/reference.server.log" >&2; exit 1; }
SERVER_PID=$(cat "$work/soak.server.pid")
METRICS=$(grep -o '"metrics_listening","detail":"[^"]*' "$OUT/soak.server.log" | tail -1 | sed 's/.*"//')
log "soak server $SERVER (pid $SERVER_PID, metrics $METRICS), reference server $REF"

# eval_check SERVER NAME OUTFILE: one checked trajectory's answer, as JSON.
eval_check() {
  local server=$1 name=$2 out=$3 spec args=()
  for spec in "${CHECKS[@]}"; do
    IFS='|' read -r -a fields <<<"$spec"
    [ "${fields[0]}" = "$name" ] && args=("${fields[@]:1}")
  done
  "$BIN/riskplan" --server="$server" eval --json --samples --timeout_ms=60000 "${args[@]}" \
    >"$out" 2>"$out.err"
}
mkdir -p "$OUT/reference"
for spec in "${CHECKS[@]}"; do
  name=${spec%%|*}
  eval_check "$REF" "$name" "$OUT/reference/$name.json" || {
    echo "soak: the reference server cannot evaluate $name: $(cat "$OUT/reference/$name.json.err")" >&2
    exit 1
  }
  rm -f "$OUT/reference/$name.json.err"
done
kill -TERM "$(cat "$work/reference.server.pid")"
wait "$(cat "$work/reference.server.pid")" 2>/dev/null || true
rm -f "$work/reference.server.pid"
log "reference answers written; reference server stopped"

# --- sampler: RSS, descriptors, threads every SAMPLE_MS ---------------------
echo "t_s,phase,rss_kb,fds,threads,shim_b_rss_kb,running_plans,fpga_up" >"$OUT/samples.csv"
echo measure >"$work/phase"
(
  shim_rss() { awk '/^VmRSS/ {print $2}' "/proc/$(cat "$work/shim_b.pid")/status" 2>/dev/null || echo 0; }
  next=$(now_ms)
  while [ ! -f "$work/stop_sampler" ]; do
    status=$(cat "/proc/$SERVER_PID/status" 2>/dev/null) || { echo "$(rel_s),dead,0,0,0,0,," >>"$OUT/samples.csv"; break; }
    rss=$(awk '/^VmRSS/ {print $2}' <<<"$status")
    threads=$(awk '/^Threads/ {print $2}' <<<"$status")
    fds=$(find "/proc/$SERVER_PID/fd" -mindepth 1 -maxdepth 1 2>/dev/null | wc -l)
    m=$(metrics)
    running=$(awk '$1 == "riskplan_running_plans" {print $2}' <<<"$m")
    up=$(awk '$1 == "riskplan_accel_fpga_workers_up" {print $2}' <<<"$m")
    echo "$(rel_s),$(cat "$work/phase"),$rss,$fds,$threads,$(shim_rss),$running,$up" >>"$OUT/samples.csv"
    next=$(( next + SAMPLE_MS ))
    while [ "$(now_ms)" -lt "$next" ] && [ ! -f "$work/stop_sampler" ]; do sleep 0.2; done
  done
) &
sampler_pid=$!
pids+=("$sampler_pid")

# Both workers up (handshake and known-answer batch) before measuring.
for _ in $(seq 1 600); do
  scrape
  [ "$(metric riskplan_accel_fpga_workers_up)" = 2 ] && break
  sleep 0.1
done
[ "$(metric riskplan_accel_fpga_workers_up)" = 2 ] || { echo "soak: the shims' workers did not come up" >&2; exit 1; }

# One round of checks first: the overridden parameters' model is built and
# every blob uploaded to both boards before anything is measured.
for spec in "${CHECKS[@]}"; do
  name=${spec%%|*}
  f="$work/checks/warm-$name.json"
  if eval_check "$SERVER" "$name" "$f"; then rm -f "$f.err"; else echo "rc=$?" >>"$f.err"; fi
done

# --- 2. the maximum of the mix ----------------------------------------------
# All four generators at once in closed loop (callers back to back: 4 for the
# long evaluation, 2 for each other RPC, 2 for plans = the planning threads),
# which saturates the server's two cores; each RPC's calls/s there is its
# share of the mix's maximum.
EVAL_LONG=(--rpc=eval --waypoints="$LONG_WAYPOINTS")
EVAL_SHORT=(--rpc=eval --polyline="$SHORT_POLYLINE")
PLAN=(--rpc=plan --start="${POSES[0]}" --goal="${POSES[1]}" --budget_ms=$PLAN_BUDGET_MS)
PING=(--rpc=ping)
ok_rps() { "$PYTHON" -c 'import json,sys; print(json.load(open(sys.argv[1]))["ok_rps"])' "$1"; }
log "measuring the maximum of the mix ($MEASURE_S s, closed loop)"
measure_pids=()
measure() {  # measure NAME CONCURRENCY ARGS...
  local name=$1 c=$2; shift 2
  "$BIN/riskplan" --server="$SERVER" load "$@" --mode=closed --concurrency="$c" \
    --duration_s="$MEASURE_S" --timeout_ms=60000 --report_json="$OUT/max-$name.json" \
    >"$OUT/max-$name.log" 2>&1 &
  measure_pids+=($!)
}
measure eval-long 4 "${EVAL_LONG[@]}"
measure eval-short 2 "${EVAL_SHORT[@]}"
measure plan $PLAN_THREADS "${PLAN[@]}"
measure ping 2 "${PING[@]}"
for p in "${measure_pids[@]}"; do
  wait "$p" || { echo "soak: measuring the mix failed; see $OUT/max-*.log" >&2; exit 1; }
done
MAX_LONG=$(ok_rps "$OUT/max-eval-long.json")
MAX_SHORT=$(ok_rps "$OUT/max-eval-short.json")
MAX_PLAN=$(ok_rps "$OUT/max-plan.json")
MAX_PING=$(ok_rps "$OUT/max-ping.json")
rate() { awk -v m="$1" 'BEGIN {r = 0.8 * m; printf "%.2f", (r < 0.1) ? 0.1 : r}'; }
RATE_LONG=$(rate "$MAX_LONG")
RATE_SHORT=$(rate "$MAX_SHORT")
RATE_PLAN=$(rate "$MAX_PLAN")
RATE_PING=$(rate "$MAX_PING")
{
  echo "the mix's maximum (calls/s, closed loop): eval-long $MAX_LONG, eval-short $MAX_SHORT, plan $MAX_PLAN, ping $MAX_PING"
  echo "offered, 80 % of it (calls/s, open loop): eval-long $RATE_LONG, eval-short $RATE_SHORT, plan $RATE_PLAN, ping $RATE_PING"
} >"$OUT/rates.txt"
log "maximum calls/s: eval-long $MAX_LONG, eval-short $MAX_SHORT, plan $MAX_PLAN, ping $MAX_PING"
log "offered (80 %): eval-long $RATE_LONG, eval-short $RATE_SHORT, plan $RATE_PLAN, ping $RATE_PING"

# --- 3. the soak: load, chaos, checks ---------------------------------------
echo soak >"$work/phase"
event soak_start "$D s"
SOAK_START_MS=$(now_ms)
load_pids=()
# At most MAX_OUTSTANDING calls of a generator in flight (see the top).
# Plans: at most 4 of the load's plus the chaos's few, under
# --max_running_plans=16, so admission never refuses one.
run_load() {  # run_load NAME RATE MAX_OUTSTANDING ARGS...
  local name=$1 r=$2 outstanding=$3; shift 3
  "$BIN/riskplan" --server="$SERVER" load "$@" --mode=open --rate="$r" --duration_s="$D" \
    --max_outstanding="$outstanding" --timeout_ms=60000 --report_json="$OUT/load-$name.json" \
    >"$OUT/load-$name.log" 2>&1 &
  load_pids+=($!)
  pids+=($!)
}
run_load eval-long "$RATE_LONG" 64 "${EVAL_LONG[@]}"
run_load eval-short "$RATE_SHORT" 64 "${EVAL_SHORT[@]}"
run_load plan "$RATE_PLAN" 4 "${PLAN[@]}"
run_load ping "$RATE_PING" 64 "${PING[@]}"

# The checker: the fixed trajectories' answers from the soak server.
(
  n=0
  next=$(now_ms)
  while [ ! -f "$work/stop" ]; do
    for spec in "${CHECKS[@]}"; do
      name=${spec%%|*}
      f="$work/checks/$(printf %05d $n)-$name.json"
      if eval_check "$SERVER" "$name" "$f"; then rm -f "$f.err"; else echo "rc=$?" >>"$f.err"; fi
    done
    n=$((n + 1))
    next=$(( next + CHECK_MS ))
    while [ "$(now_ms)" -lt "$next" ] && [ ! -f "$work/stop" ]; do sleep 0.2; done
  done
) &
checker_pid=$!
pids+=("$checker_pid")

# The chaos loop.
(
  kill_at=$(( SOAK_START_MS + KILL_MS / 2 ))
  stop_at=$(( kill_at + KILL_MS / 2 ))
  cancel_at=$(( SOAK_START_MS + CANCEL_MS / 2 ))
  cont_at=0
  k=0
  port_a=${SHIM_A##*:}
  while [ ! -f "$work/stop" ]; do
    t=$(now_ms)
    if [ "$t" -ge "$kill_at" ]; then
      pid=$(cat "$work/shim_a.pid")
      kill -KILL "$pid" 2>/dev/null || true
      wait "$pid" 2>/dev/null || true
      event shim_kill "A pid $pid"
      restarted=""
      for _ in $(seq 1 20); do
        if address=$(start_shim a "$port_a"); then restarted=$address; break; fi
        sleep 0.5
      done
      if [ -n "$restarted" ]; then event shim_restart "A pid $(cat "$work/shim_a.pid")"
      else event shim_restart_failed "A on port $port_a"; fi
      kill_at=$(( kill_at + KILL_MS ))
    fi
    if [ "$t" -ge "$stop_at" ]; then
      kill -STOP "$(cat "$work/shim_b.pid")" && event shim_stop "B for up to 5 s"
      cont_at=$(( t + 1000 + RANDOM % 4001 ))
      stop_at=$(( stop_at + KILL_MS ))
    fi
    if [ "$cont_at" -gt 0 ] && [ "$t" -ge "$cont_at" ]; then
      kill -CONT "$(cat "$work/shim_b.pid")" && event shim_cont "B"
      cont_at=0
    fi
    if [ "$t" -ge "$cancel_at" ]; then
      k=$((k + 1))
      i=$((RANDOM % 6)); j=$(( (i + 1 + RANDOM % 5) % 6 ))
      args=(--start="${POSES[$i]}" --goal="${POSES[$j]}" --budget_ms=5000 --seed=$RANDOM)
      if [ $((k % 2)) -eq 1 ]; then
        deadline=$(( 50 + RANDOM % 751 ))
        ( rc=0; "$BIN/riskplan" --server="$SERVER" plan "${args[@]}" --timeout_ms=$deadline \
            >/dev/null 2>"$work/chaos/deadline-$k.err" || rc=$?
          echo "$rc" >"$work/chaos/deadline-$k.rc" ) &
        event plan_deadline "${deadline} ms"
      else
        delay=$(( 100 + RANDOM % 1901 ))
        "$BIN/riskplan" --server="$SERVER" plan "${args[@]}" --timeout_ms=60000 >/dev/null \
          2>"$work/chaos/killed-$k.err" &
        victim=$!
        ( sleep "$(awk -v d=$delay 'BEGIN {print d / 1000}')"
          if kill -KILL "$victim" 2>/dev/null; then echo killed; else echo ended; fi \
            >"$work/chaos/killed-$k.result" ) &
        event plan_client_kill "after ${delay} ms"
      fi
      cancel_at=$(( cancel_at + CANCEL_MS ))
    fi
    sleep 0.1
  done
  # Leave both shims running.
  [ "$cont_at" -gt 0 ] && kill -CONT "$(cat "$work/shim_b.pid")" && event shim_cont "B (end)"
  kill -0 "$(cat "$work/shim_a.pid")" 2>/dev/null || { start_shim a "$port_a" >/dev/null && event shim_restart "A (end)"; }
  wait
) 2>>"$OUT/chaos.log" &
chaos_pid=$!
pids+=("$chaos_pid")

# Wait for the load generators (they stop sending after DURATION); a
# generator still running 120 s later is a hang.
hung=""
deadline=$(( SOAK_START_MS + D * 1000 + 120000 ))
for p in "${load_pids[@]}"; do
  while kill -0 "$p" 2>/dev/null && [ "$(now_ms)" -lt "$deadline" ]; do
    [ "$(now_ms)" -ge $(( SOAK_START_MS + D * 1000 )) ] && touch "$work/stop"
    sleep 0.5
  done
  if kill -0 "$p" 2>/dev/null; then hung="$hung load-pid-$p"; kill -KILL "$p"; fi
  wait "$p" 2>/dev/null || true
done
touch "$work/stop"
wait "$chaos_pid" 2>/dev/null || true
wait "$checker_pid" 2>/dev/null || true
event soak_end ""
echo after >"$work/phase"
log "load ended; chaos stopped"

# --- 4. recovery and drain ----------------------------------------------------
recovered=0
for _ in $(seq 1 600); do
  scrape
  if [ "$(metric riskplan_accel_fpga_workers_up)" = 2 ] && [ "$(metric riskplan_running_plans)" = 0 ]; then
    recovered=1; break
  fi
  sleep 0.1
done
event recovery "$([ $recovered = 1 ] && echo ok || echo 'not within 60 s')"
# One last sample of the idle server, then the final metrics.
sleep $(( SAMPLE_MS / 1000 ))
touch "$work/stop_sampler"
wait "$sampler_pid" 2>/dev/null || true
scrape
cp "$work/metrics.txt" "$OUT/metrics-final.txt"
kill -TERM "$SERVER_PID"
drain_rc=timeout
for _ in $(seq 1 300); do
  if ! kill -0 "$SERVER_PID" 2>/dev/null; then
    drain_rc=0; wait "$SERVER_PID" 2>/dev/null || drain_rc=$?
    break
  fi
  sleep 0.1
done
[ "$drain_rc" = timeout ] && kill -KILL "$SERVER_PID"
rm -f "$work/soak.server.pid"
for s in a b; do
  p=$(cat "$work/shim_$s.pid")
  kill -TERM "$p" 2>/dev/null || true
  for _ in $(seq 1 100); do kill -0 "$p" 2>/dev/null || break; sleep 0.1; done
  kill -KILL "$p" 2>/dev/null || true
  rm -f "$work/shim_$s.pid"
done
# The chaos plans' outcomes, for the report.
for f in "$work"/chaos/deadline-*.rc; do
  [ -f "$f" ] || continue
  echo "deadline,$(cat "$f"),$(tr '\n,' '  ' <"${f%.rc}.err")"
done >"$OUT/chaos-plans.csv"
for f in "$work"/chaos/killed-*.result; do
  [ -f "$f" ] && echo "killed,$(cat "$f"),$(tr '\n,' '  ' <"${f%.result}.err")"
done >>"$OUT/chaos-plans.csv"

# --- 5. judge ----------------------------------------------------------------
# (The checked answers stay in the work directory, about 0.4 MB each; the
# report copies wrong ones into $OUT/wrong/.)
"$PYTHON" scripts/soak_report.py --out="$OUT" --checks="$work/checks" --duration_s="$D" \
  --soak_start_s="$(awk -v a="$SOAK_START_MS" -v b="$T0" 'BEGIN {printf "%.1f", (a - b) / 1000}')" \
  --recovered="$recovered" --drain_rc="$drain_rc" --hung="$hung" \
  --command="scripts/soak.sh $1 (seed $SEED)"
