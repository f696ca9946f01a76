#!/usr/bin/env bash
# Plays deploy/kubernetes/riskplan-server.yaml with `podman kube play`: three
# replicas of its Deployment (a test overlay that changes only what a laptop
# lacks), their probes answered on the health port, fleets and an
# EvaluateRisk load spread over them by the multi-address client, one
# replica's container killed and one stopped (drained) mid-run; every
# mission must get exactly one final result and every call an answer. Not
# part of CI (a few minutes; needs the image of scripts/image-build.sh).
# docs/deploy.md.
set -euo pipefail

usage() {
  cat <<'EOF'
Usage: bash scripts/kube-drill.sh [--image=NAME] [--client=PATH] [--workdir=DIR] [--keep]

  1. packages (podman, runc, catatonit, ... through scripts/install-deps.sh);
  2. the manifests of deploy/kubernetes validated offline against the
     Kubernetes schemas (scripts/manifest-validate.sh);
  3. mutual TLS and tokens as the manifest's Secrets hold them (a throw-away
     CA, tests/integration/test_pki.sh), the map volume riskplan-maps (the
     manifest's PersistentVolumeClaim) with demo-city written by the image's
     riskplan-tool;
  4. the overlay (scripts/kube-overlay.py; validated too) played: three
     Deployments of one replica each, host network, loopback ports; time to
     every replica's health port SERVING (what the gRPC probes ask);
  5. an open-loop EvaluateRisk load and fleets of six missions (one
     `riskplan fleet` each, started one at a time until every replica holds
     one: 3 to 9 fleets), every client given the three replicas as one
     --server list; when every replica has missions in flight, replica 0's
     container is killed (SIGKILL) and replica 1's stopped (SIGTERM: its
     drain);
  6. checks: every fleet exits 0 with exactly one final per mission, the
     load has no error, the drained replica exited 0; then `podman kube down`.

Run as root, after scripts/image-build.sh (the image must be in local storage).

  --image=NAME    the image (default localhost/riskplan:latest)
  --client=PATH   the host's riskplan client (default build/bin/riskplan)
  --workdir=DIR   certificates, overlay and logs (default /var/tmp/riskplan-kube-drill)
  --keep          leave the pods and the map volume (default: removed at the end)
  -h, --help      this text
EOF
}

PROG=kube-drill
SRC=$(cd "$(dirname "$0")/.." && pwd)
PODMAN_SRC=$SRC
# shellcheck source=scripts/podman-lib.sh
. "$SRC/scripts/podman-lib.sh"

IMAGE=localhost/riskplan:latest
CLIENT=$SRC/build/bin/riskplan
WORKDIR=/var/tmp/riskplan-kube-drill
KEEP=0
for arg in "$@"; do
  case "$arg" in
    -h | --help) usage; exit 0 ;;
    --image=*) IMAGE=${arg#--image=} ;;
    --client=*) CLIENT=${arg#--client=} ;;
    --workdir=*) WORKDIR=${arg#--workdir=} ;;
    --keep) KEEP=1 ;;
    *) die "unknown argument '$arg' (--help for usage)" ;;
  esac
done
[ "$(id -u)" -eq 0 ] || die "must run as root"
case "$WORKDIR" in /*) ;; *) WORKDIR="$PWD/$WORKDIR" ;; esac
[ "$WORKDIR" != / ] || die "--workdir=/ is not allowed"
[ -x "$CLIENT" ] || die "no host client at $CLIENT (build it: ninja -C build riskplan, or give --client=PATH)"

REPLICAS=3
MISSIONS=6
MANIFEST=$SRC/deploy/kubernetes/riskplan-server.yaml
OVERLAY=$WORKDIR/overlay.yaml
BG_PIDS=()
cleanup() {
  local rc=$? p
  for p in "${BG_PIDS[@]}"; do kill "$p" 2>/dev/null || true; done
  if [ -f "$OVERLAY" ] && [ "$KEEP" -eq 0 ]; then
    podman kube down "$OVERLAY" >/dev/null 2>&1 || true
    podman volume rm -f riskplan-maps >/dev/null 2>&1 || true
  fi
  if [ "${#PHASES[@]}" -gt 0 ]; then summary >&2; fi
  if [ "$rc" -ne 0 ]; then say "FAILED (exit $rc) in phase: ${PHASE_NAME:-setup}"; fi
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

# ---------------------------------------------------------------- 1, 2
phase_start "packages"
install_podman_deps
podman image exists "$IMAGE" || die "no image $IMAGE in local storage: run scripts/image-build.sh first"
phase_end

phase_start "manifests validated offline (Kubernetes schemas)"
bash "$SRC/scripts/manifest-validate.sh" "$SRC"/deploy/kubernetes/*.yaml >&2 || die "deploy/kubernetes is not valid"
phase_end

# ---------------------------------------------------------------- 3
phase_start "TLS, tokens and the map volume"
if [ -f "$OVERLAY" ]; then podman kube down "$OVERLAY" >/dev/null 2>&1 || true; fi
rm -rf --one-file-system "$WORKDIR"
mkdir -p "$WORKDIR"
PKI=$WORKDIR/pki
bash "$SRC/tests/integration/test_pki.sh" init "$PKI"
start=$(date -u -d '-1 hour' +%Y%m%d%H%M%SZ); end=$(date -u -d '+2 days' +%Y%m%d%H%M%SZ)
bash "$SRC/tests/integration/test_pki.sh" issue "$PKI" server a riskplan-server \
  "DNS:riskplan-server,IP:127.0.0.1" server "$start" "$end"
bash "$SRC/tests/integration/test_pki.sh" issue "$PKI" drill-client a drill-client "" client "$start" "$end"
SECRETS=$WORKDIR/secrets
mkdir -p "$SECRETS/riskplan-server-tls" "$SECRETS/riskplan-server-tokens"
cp "$PKI/server.pem" "$SECRETS/riskplan-server-tls/tls.crt"
cp "$PKI/server.key" "$SECRETS/riskplan-server-tls/tls.key"
cp "$PKI/ca-a.pem" "$SECRETS/riskplan-server-tls/ca.crt"
token=$(openssl rand -hex 32)
printf '%s' "$token" >"$WORKDIR/drill.token"
printf '%s drill operator\n' "$(printf '%s' "$token" | sha256sum | cut -c1-64)" >"$SECRETS/riskplan-server-tokens/tokens"
# As the Secret volumes hold them: mode 0440 (defaultMode), readable by the
# pod's user (podman 4.3 does not apply fsGroup: the files are the user's).
chown -R 10001:10001 "$SECRETS"
chmod 0550 "$SECRETS"/*; chmod 0440 "$SECRETS"/*/*
TLS=(--tls_ca="$PKI/ca-a.pem" --tls_cert="$PKI/drill-client.pem" --tls_key="$PKI/drill-client.key"
  --tls_server_name=riskplan-server --token_file="$WORKDIR/drill.token")
# The PersistentVolumeClaim riskplan-maps: podman plays it as the named
# volume of that name; demo-city written into it by the image's own tool.
podman volume rm -f riskplan-maps >/dev/null 2>&1 || true
podman volume create riskplan-maps >/dev/null
podman run --rm --network=host --user 0 -v riskplan-maps:/maps --entrypoint /usr/local/bin/riskplan-tool \
  "$IMAGE" write-map --out=/maps/demo-city >&2 || die "riskplan-tool write-map failed in the image"
chown -R 10001:10001 "$(podman volume inspect --format '{{.Mountpoint}}' riskplan-maps)"
phase_end

# ---------------------------------------------------------------- 4
phase_start "podman kube play: $REPLICAS replicas to SERVING"
GRPC=(); HEALTH=(); METRICS=(); ports=""
for ((i = 0; i < REPLICAS; i++)); do
  GRPC+=("$(free_port)"); HEALTH+=("$(free_port)"); METRICS+=("$(free_port)")
  ports+="${ports:+;}${GRPC[$i]},${HEALTH[$i]},${METRICS[$i]}"
done
/usr/bin/python3 "$SRC/scripts/kube-overlay.py" "$MANIFEST" --replicas="$REPLICAS" --ports="$ports" \
  --image="$IMAGE" --secrets="$SECRETS" >"$OVERLAY" || die "kube-overlay.py failed"
bash "$SRC/scripts/manifest-validate.sh" "$OVERLAY" >&2 || die "the overlay is not valid"
t_play=$(now)
# podman logs an error per container for the healthchecks it cannot add
# without systemd (the probes are asked below, as the kubelet would).
podman kube play "$OVERLAY" >"$WORKDIR/play.log" 2>&1 || { cat "$WORKDIR/play.log" >&2; die "podman kube play failed"; }
for ((i = 0; i < REPLICAS; i++)); do
  wait_serving 127.0.0.1:"${HEALTH[$i]}" 120 || {
    podman logs "riskplan-server-$i-pod-0-riskplan-server" >&2 || true
    die "replica $i's health port did not say SERVING"; }
done
serving_s=$(awk -v a="$t_play" -v b="$(now)" 'BEGIN { printf "%.1f", b - a }')
say "all $REPLICAS replicas SERVING ${serving_s} s after podman kube play"
podman pod ps --filter label=app=riskplan-server --format '{{.Name}} {{.Status}} {{.NumberOfContainers}} containers' >&2 || true
CONTAINERS=()
for ((i = 0; i < REPLICAS; i++)); do
  c=$(podman ps --filter "pod=riskplan-server-$i-pod-0" --filter name=riskplan-server-$i-pod-0-riskplan-server --format '{{.Names}}')
  [ -n "$c" ] || die "no container of replica $i"
  CONTAINERS+=("$c")
  ro=$(podman inspect --format '{{.HostConfig.ReadonlyRootfs}} {{.Config.User}}' "$c")
  st=$(health_status 127.0.0.1:"${HEALTH[$i]}")
  say "replica $i: container $c (read-only root, user: $ro), gRPC 127.0.0.1:${GRPC[$i]} (mutual TLS), health 127.0.0.1:${HEALTH[$i]} $st, metrics 127.0.0.1:${METRICS[$i]}"
done
phase_end

# ---------------------------------------------------------------- 5
phase_start "fleets and EvaluateRisk over the replicas; one killed, one drained"
metric() {  # metric PORT NAME: the value of an unlabelled series, or nothing
  /usr/bin/python3 - "$1" "$2" <<'EOF' 2>/dev/null || true
import sys, urllib.request
try:
    text = urllib.request.urlopen(f"http://127.0.0.1:{sys.argv[1]}/metrics", timeout=2).read().decode()
except Exception:
    sys.exit(0)
for line in text.splitlines():
    if line.startswith(sys.argv[2] + " ") or line.startswith(sys.argv[2] + "{"):
        print(line.rsplit(" ", 1)[1]); break
EOF
}
# Fleets of six missions between points of demo-city that the docs plan
# between, 3 s budgets: four goals, so four groups (missions to one goal
# share a tree); a replica of --plan_threads=2 plans two groups at once and
# queues the others.
pairs=("1200,1500,250,0.785 6800,6500,250,0.785" "5200,1400,260,1.571 2600,3900,250,0"
  "2000,3000,250,0 5200,1400,260,1.571" "6800,6500,250,0.785 1200,1500,250,0.785"
  "2600,3900,250,0 6800,6500,250,0.785" "1200,1500,250,0.785 2600,3900,250,0")
write_fleet() {  # write_fleet F: WORKDIR/fleet-F.json
  local f=$1 m s g
  {
    echo "{\"tenant\": \"fleet-$f\", \"missions\": ["
    for ((m = 0; m < MISSIONS; m++)); do
      read -r s g <<<"${pairs[$m]}"
      echo "  {\"id\": \"f$f-m$m\", \"start\": \"$s\", \"goal\": \"$g\", \"budget_ms\": 3000}$([ "$m" -lt $((MISSIONS - 1)) ] && echo ,)"
    done
    echo "]}"
  } >"$WORKDIR/fleet-$f.json"
}
# Every client is given the same list of the three replicas.
SERVERS=""
for ((i = 0; i < REPLICAS; i++)); do SERVERS+="${SERVERS:+,}127.0.0.1:${GRPC[$i]}"; done
admitted() {  # admitted I: fleet missions replica I has admitted so far
  local v
  v=$(metric "${METRICS[$1]}" riskplan_fleet_missions_admitted_total)
  echo "${v:-0}"
}
"$CLIENT" --server="$SERVERS" "${TLS[@]}" load --rpc=eval --mode=open --rate=100 --duration_s=30 \
  --waypoints="1200,1500,250,0.785; 4000,4000,250,0.785; 6800,6500,250,0.785" \
  >"$WORKDIR/load.out" 2>&1 &
LOAD_PID=$!; BG_PIDS+=("$LOAD_PID")
# One `riskplan fleet` (its own channel) at a time, each seen admitted by a
# replica before the next starts, until every replica holds a fleet: a new
# channel's round-robin starts at a replica of gRPC's choosing, so which
# replica a fleet lands on is not ours to set. At most MAX_FLEETS.
MAX_FLEETS=9
FLEET_PIDS=(); HOME_OF=(); declare -A HOLDS=()
for ((f = 0; f < MAX_FLEETS && ${#HOLDS[@]} < REPLICAS; f++)); do
  write_fleet "$f"
  before=(); for ((i = 0; i < REPLICAS; i++)); do before+=("$(admitted "$i")"); done
  "$CLIENT" --server="$SERVERS" "${TLS[@]}" fleet --missions="$WORKDIR/fleet-$f.json" \
    >"$WORKDIR/fleet-$f.out" 2>"$WORKDIR/fleet-$f.err" &
  FLEET_PIDS+=("$!"); BG_PIDS+=("$!")
  home=""
  for _ in $(seq 1 100); do
    for ((i = 0; i < REPLICAS; i++)); do
      if [ "$(admitted "$i")" -gt "${before[$i]}" ]; then home=$i; break; fi
    done
    [ -n "$home" ] && break
    sleep 0.1
  done
  [ -n "$home" ] || die "fleet $f was admitted by no replica within 10 s"
  HOME_OF+=("$home"); HOLDS[$home]=1
  say "fleet $f: admitted by replica $home"
done
NFLEETS=${#FLEET_PIDS[@]}
[ "${#HOLDS[@]}" -eq "$REPLICAS" ] || die "$NFLEETS fleets did not reach every replica"
# Until every replica has missions in flight (at most 10 s).
busy=""
for _ in $(seq 1 100); do
  busy=""
  all=1
  for ((i = 0; i < REPLICAS; i++)); do
    v=$(metric "${METRICS[$i]}" riskplan_missions_in_flight); busy+=" ${v:-?}"
    awk -v v="${v:-0}" 'BEGIN { exit !(v > 0) }' || all=0
  done
  [ "$all" -eq 1 ] && break
  sleep 0.1
done
say "missions in flight per replica before the signals:$busy"
EVAL_OK='riskplan_rpcs_total{code="OK",method="EvaluateRisk"}'
spread=""
for ((i = 0; i < REPLICAS; i++)); do
  spread+=" replica $i: $(metric "${METRICS[$i]}" riskplan_fleet_missions_admitted_total) missions admitted, $(metric "${METRICS[$i]}" "$EVAL_OK") EvaluateRisk OK;"
done
say "before the signals:$spread"
[ "$all" -eq 1 ] || die "not every replica had missions in flight (the fleets did not spread)"
t_sig=$(now)
podman kill --signal KILL "${CONTAINERS[0]}" >/dev/null || die "podman kill of replica 0 failed"
say "replica 0 (${CONTAINERS[0]}): SIGKILL"
podman stop -t 20 "${CONTAINERS[1]}" >"$WORKDIR/stop.out" 2>&1 &
STOP_PID=$!; BG_PIDS+=("$STOP_PID")
say "replica 1 (${CONTAINERS[1]}): podman stop (SIGTERM, then 20 s: the pod's terminationGracePeriodSeconds)"
# The drained replica says NOT_SERVING while it drains.
drain_health=""
for _ in $(seq 1 30); do
  drain_health=$(health_status 127.0.0.1:"${HEALTH[1]}")
  [ "$drain_health" = SERVING ] || break
  sleep 0.1
done
say "replica 1's health port during the drain: $drain_health"
fleet_rcs=()
for ((f = 0; f < NFLEETS; f++)); do
  set +e; wait "${FLEET_PIDS[$f]}"; fleet_rcs+=("$?"); set -e
done
fleets_s=$(awk -v a="$t_sig" -v b="$(now)" 'BEGIN { printf "%.1f", b - a }')
set +e; wait "$STOP_PID"; stop_rc=$?; wait "$LOAD_PID"; load_rc=$?; set -e
BG_PIDS=()
phase_end

# ---------------------------------------------------------------- 6
phase_start "checks"
failed=0
for ((f = 0; f < NFLEETS; f++)); do
  out=$WORKDIR/fleet-$f.out
  finals=$(grep -cE '^\[[0-9]+/[0-9]+\] ' "$out" || true)
  resub=$(grep -c 're-submission' "$WORKDIR/fleet-$f.err" || true)
  dup=$(grep -oE '^\[[0-9]+/[0-9]+\] [^:]+' "$out" | awk '{print $2}' | sort | uniq -d | tr '\n' ' ')
  missing=""
  for ((m = 0; m < MISSIONS; m++)); do
    grep -qE "^\[[0-9]+/[0-9]+\] f$f-m$m: " "$out" || missing+="f$f-m$m "
  done
  say "fleet $f (admitted by replica ${HOME_OF[$f]}): exit ${fleet_rcs[$f]}, $finals finals of $MISSIONS missions, $resub re-submissions${dup:+, twice: $dup}${missing:+, none for: $missing}"
  grep 're-submission' "$WORKDIR/fleet-$f.err" | sed 's/^/    /' >&2 || true
  if [ "${fleet_rcs[$f]}" -ne 0 ] || [ "$finals" -ne "$MISSIONS" ] || [ -n "$dup" ] || [ -n "$missing" ]; then
    failed=1; cat "$WORKDIR/fleet-$f.err" >&2
  fi
done
grep -E 'sent .* completed|codes:' "$WORKDIR/load.out" | sed 's/^/    /' >&2 || true
if [ "$load_rc" -ne 0 ] || ! grep -qE 'errors 0$' "$WORKDIR/load.out" || grep -qE '^  codes: .*[A-Z_]+=[0-9]+.*[A-Z_]+=' "$WORKDIR/load.out"; then
  say "the EvaluateRisk load had errors (exit $load_rc):"; tail -n 8 "$WORKDIR/load.out" >&2; failed=1
fi
drained_exit=$(podman inspect --format '{{.State.ExitCode}}' "${CONTAINERS[1]}" 2>/dev/null || echo '?')
podman logs "${CONTAINERS[1]}" >"$WORKDIR/replica-1.log" 2>&1 || true
[ "$stop_rc" -eq 0 ] && [ "$drained_exit" = 0 ] || { say "replica 1 did not exit 0 after SIGTERM (exit $drained_exit)"; failed=1; }
say "after the signals: replica 2 answered $(metric "${METRICS[2]}" "$EVAL_OK") EvaluateRisk calls OK in all, $(metric "${METRICS[2]}" riskplan_fleet_missions_admitted_total) fleet missions admitted in all"
killed_state=$(podman inspect --format '{{.State.Status}} exit {{.State.ExitCode}}, restarts {{.RestartCount}}' "${CONTAINERS[0]}" 2>/dev/null || echo '?')
say "replica 0 after SIGKILL: $killed_state; replica 1 after the drain: exit $drained_exit; replica 2: $(health_status 127.0.0.1:"${HEALTH[2]}")"
say "fleets done ${fleets_s} s after the signals"
[ "$failed" -eq 0 ] || die "see above"
phase_end
echo "kube-drill: OK: $REPLICAS replicas played from the Deployment; every mission had exactly one final, every EvaluateRisk call was answered, through a SIGKILL and a drain" >&2
