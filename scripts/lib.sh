# shellcheck shell=bash
# Shell functions shared by the scripts; sourced (`source scripts/lib.sh`),
# not run.

# start_and_wait PID_VAR ADDRESS_VAR DIR LOG TIMEOUT_S COMMAND [ARG...]
#
# Starts COMMAND in the background, its stderr into LOG, and waits up to
# TIMEOUT_S seconds for the one readiness line that riskplan's servers print
# on stdout once they serve: "NAME listening on HOST:PORT", NAME being
# COMMAND's file name. Stdout is read through a FIFO made in DIR and kept open
# (on a new file descriptor) for the program's lifetime, so that its later
# writes do not fail. Sets the variable named PID_VAR to the program's pid as
# soon as it starts (so that an EXIT trap can stop it) and ADDRESS_VAR to
# HOST:PORT. If no such line comes in time, prints LOG on stderr and exits 1.
start_and_wait() {
  local pid_var=$1 address_var=$2 dir=$3 log=$4 timeout_s=$5
  shift 5
  local name=${1##*/}
  local fifo="$dir/$name" fd line
  mkfifo "$fifo"
  "$@" 2>"$log" >"$fifo" &
  printf -v "$pid_var" '%s' "$!"
  exec {fd}<"$fifo"
  if ! read -r -t "$timeout_s" line <&"$fd" || [[ "$line" != "$name listening on "* ]]; then
    echo "$(basename "$0" .sh): $name did not start; its log:" >&2
    cat "$log" >&2
    exit 1
  fi
  printf -v "$address_var" '%s' "${line#"$name listening on "}"
}

# bg_build_start PASS / bg_build_wait / bg_build_stop
#
# Builds the sanitizer pass PASS (asan or tsan; `scripts/sanitize.sh
# --build-only PASS`) in the background at nice 10 while the caller runs a test
# suite in the foreground. The suites leave part of the two cores idle (tests
# waiting on servers, sockets and timers), which the build takes without
# slowing them: both are in the caller's session, and nice orders the
# processes of one session (sched(7), autogroups; a new session would get an
# equal share instead). The build runs in its own process group, so that
# bg_build_stop (the caller's EXIT trap) ends all of it; its output is kept and
# printed by bg_build_wait, which returns 0 either way: a failed build fails
# again, with its errors, when the pass builds in the foreground.
BG_BUILD_PID=""
BG_BUILD_LOG=""
bg_build_start() {
  BG_BUILD_LOG=$(mktemp)
  set -m
  nice -n 10 bash scripts/sanitize.sh --build-only "$1" >"$BG_BUILD_LOG" 2>&1 &
  BG_BUILD_PID=$!
  set +m
  echo "$(basename "$0" .sh): building the $1 pass in the background (nice 10)"
}
bg_build_wait() {
  [ -n "$BG_BUILD_PID" ] || return 0
  local rc=0
  wait "$BG_BUILD_PID" || rc=$?
  BG_BUILD_PID=""
  echo "$(basename "$0" .sh): the background build's output (exit $rc):"
  cat "$BG_BUILD_LOG"
  rm -f "$BG_BUILD_LOG"
}
bg_build_stop() {
  [ -n "$BG_BUILD_PID" ] || return 0
  kill -- -"$BG_BUILD_PID" 2>/dev/null || true
  wait "$BG_BUILD_PID" 2>/dev/null || true
  BG_BUILD_PID=""
  rm -f "$BG_BUILD_LOG"
}

# start_demo_server LOG [ARG...] / stop_demo_server
#
# For the demo scripts: makes a temporary directory (WORKDIR), sets an EXIT
# trap that stops the server and removes the directory, and starts
# $BIN/riskplan-server on 127.0.0.1 (a free port; the built-in demo-city)
# with start_and_wait, its stderr into LOG (empty: $WORKDIR/server.log) and
# ARG... as extra flags. Sets SERVER_PID and ADDRESS (HOST:PORT).
# stop_demo_server stops it (SIGTERM) and returns the server's exit status,
# so that a server that does not end cleanly fails the demo.
SERVER_PID=""
WORKDIR=""
stop_demo_server() {
  [ -n "$SERVER_PID" ] || return 0
  local pid=$SERVER_PID rc=0
  SERVER_PID=""
  kill -TERM "$pid" 2>/dev/null || true
  wait "$pid" || rc=$?
  return "$rc"
}
demo_cleanup() {
  stop_demo_server 2>/dev/null || true
  if [ -n "$WORKDIR" ]; then rm -rf "$WORKDIR"; fi
}
start_demo_server() {
  local log=$1
  shift
  WORKDIR=$(mktemp -d)
  trap demo_cleanup EXIT
  start_and_wait SERVER_PID ADDRESS "$WORKDIR" "${log:-$WORKDIR/server.log}" 120 \
    "$BIN/riskplan-server" --listen=127.0.0.1:0 --rpc_log=false "$@"
}
