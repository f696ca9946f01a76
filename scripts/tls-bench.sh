#!/usr/bin/env bash
# What TLS costs on the gRPC port, measured in one run (docs/benchmarks.md,
# "TLS"): three servers side by side on 127.0.0.1, plaintext, mutual TLS, and
# mutual TLS with a token file, loaded in turns with the same settings by
# `riskplan load` (closed loop): Ping, EvaluateRisk, and Connect (a new
# connection, TLS handshake included, and one Ping per call). Each pair of
# phases runs REPEAT times, alternating, and the report gives the median of
# each figure. Certificates come from tests/integration/test_pki.sh (made
# here, thrown away).
#
#   scripts/tls-bench.sh [SECONDS_PER_PHASE] [REPEAT] [CONCURRENCY]
#
# Environment: BUILD_DIR (build), OUT_DIR (build/tls-bench).
set -euo pipefail
cd "$(dirname "$0")/.."
SECONDS_PER_PHASE=${1:-10}
REPEAT=${2:-3}
CONCURRENCY=${3:-4}
BIN=${BUILD_DIR:-build}/bin
OUT=${OUT_DIR:-${BUILD_DIR:-build}/tls-bench}
mkdir -p "$OUT"
work=$(mktemp -d)
pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
  wait 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

pki=tests/integration/test_pki.sh
from=$(date -u -d '-1 hour' +%Y%m%d%H%M%SZ)
until=$(date -u -d '+1 day' +%Y%m%d%H%M%SZ)
bash $pki init "$work"
bash $pki issue "$work" server a localhost "DNS:localhost,IP:127.0.0.1" server "$from" "$until"
bash $pki issue "$work" client a bench "" client "$from" "$until"
token=bench-token-$RANDOM$RANDOM
printf '%s' "$token" >"$work/operator.token"
printf '%s bench operator\n' "$(printf '%s' "$token" | sha256sum | cut -c1-64)" >"$work/tokens.txt"

# start NAME FLAGS...: a server, its port in $port.
start() {
  local name=$1
  shift
  "$BIN/riskplan-server" --listen=127.0.0.1:0 --rpc_log=false "$@" \
    >"$work/$name.ready" 2>"$OUT/$name.log" &
  pids+=($!)
  for _ in $(seq 600); do
    grep -q 'listening on' "$work/$name.ready" 2>/dev/null && break
    sleep 0.1
  done
  port=$(sed -n 's/.*listening on .*:\([0-9]*\)$/\1/p' "$work/$name.ready")
  [ -n "$port" ] || { echo "tls-bench: $name did not start" >&2; cat "$OUT/$name.log" >&2; exit 1; }
}
start plain
plain_port=$port
start mtls --tls_cert="$work/server.pem" --tls_key="$work/server.key" \
  --tls_client_ca="$work/ca-a.pem"
mtls_port=$port
start tls --tls_cert="$work/server.pem" --tls_key="$work/server.key" \
  --tls_client_ca="$work/ca-a.pem" --token_file="$work/tokens.txt"
tls_port=$port
plain=(--server=127.0.0.1:$plain_port)
mtls=(--server=localhost:$mtls_port --tls_ca="$work/ca-a.pem" --tls_cert="$work/client.pem"
  --tls_key="$work/client.key")
tls=(--server=localhost:$tls_port --tls_ca="$work/ca-a.pem" --tls_cert="$work/client.pem"
  --tls_key="$work/client.key" --token_file="$work/operator.token")
eval_flags=(--polyline='300,375,240; 1000,400,250; 1700,1625,250; 3000,3500,260')

# phase NAME RPC SERVER_FLAGS...: one closed-loop run, its JSON report kept.
phase() {
  local name=$1 rpc=$2
  shift 2
  "$BIN/riskplan" "$@" load --rpc="$rpc" --mode=closed --concurrency="$CONCURRENCY" \
    --duration_s="$SECONDS_PER_PHASE" "${eval_flags[@]}" --report_json="$OUT/$name.json" >/dev/null
}
for i in $(seq "$REPEAT"); do
  for rpc in ping eval connect; do
    phase "$rpc-plain-$i" "$rpc" "${plain[@]}"
    phase "$rpc-mtls-$i" "$rpc" "${mtls[@]}"
    phase "$rpc-tls-$i" "$rpc" "${tls[@]}"
  done
done

python3 - "$OUT" "$REPEAT" <<'EOF'
import json, statistics, sys
out, repeat = sys.argv[1], int(sys.argv[2])
def load(name):
    with open(f"{out}/{name}.json") as f:
        return json.load(f)
def med(values):
    return statistics.median(values)
print(f"{'rpc':8} {'link':6} {'ok calls/s':>12} {'p50 ms':>8} {'p99 ms':>8} {'errors':>7}")
summary = {}
for rpc in ("ping", "eval", "connect"):
    for link in ("plain", "mtls", "tls"):
        runs = [load(f"{rpc}-{link}-{i}") for i in range(1, repeat + 1)]
        rps = med([r["ok_rps"] for r in runs])
        p50 = med([r["latency_ms"]["p50"] for r in runs])
        p99 = med([r["latency_ms"]["p99"] for r in runs])
        errors = sum(r["errors"] for r in runs)
        summary[(rpc, link)] = (rps, p50)
        print(f"{rpc:8} {link:6} {rps:12.1f} {p50:8.3f} {p99:8.3f} {errors:7d}")
print("mtls: mutual TLS; tls: mutual TLS and tokens (what deploy/ runs)")
for rpc in ("ping", "eval", "connect"):
    rp, lp = summary[(rpc, "plain")]
    for link in ("mtls", "tls"):
        rt, lt = summary[(rpc, link)]
        print(f"{rpc}: {link}/plaintext throughput {rt / rp:.3f}, p50 latency {lt / lp:.3f}x")
EOF
