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
