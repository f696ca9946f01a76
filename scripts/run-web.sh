#!/usr/bin/env bash
# The web view: builds riskplan if needed, starts riskplan-server on demo-city
# (and on a twin of it placed on WGS84 near Luxembourg, "demo-city-wgs84", whose
# trajectories download as GeoJSON, KML and QGroundControl .plan), starts
# riskplan-web in front of it, prints the URL to open, and serves until Ctrl-C
# (which stops both). docs/web.md says what the page does.
#   WEB_LISTEN   the gateway's address (default 127.0.0.1:8080; 127.0.0.1:0 picks a port)
#   BUILD_DIR, OUT_DIR as for run-demo.sh; extra arguments go to riskplan-web.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh >&2
BIN=${BUILD_DIR:-build}/bin
OUT=${OUT_DIR:-out}
LISTEN=${WEB_LISTEN:-127.0.0.1:8080}
MAPS="$OUT/web-maps"
mkdir -p "$OUT"

# The maps, written once: demo-city as a bundle, and its geo-referenced twin
# (the same layer files, a manifest with a name and a geo-reference).
if [ ! -f "$MAPS/demo-city/manifest.json" ]; then
  "$BIN/riskplan-tool" write-map --out="$MAPS/demo-city" >&2
fi
if [ ! -f "$MAPS/demo-city-wgs84/manifest.json" ]; then
  mkdir -p "$MAPS/demo-city-wgs84"
  for f in "$MAPS"/demo-city/*; do
    [ "$(basename "$f")" = manifest.json ] || cp "$f" "$MAPS/demo-city-wgs84/"
  done
  python3 - "$MAPS/demo-city/manifest.json" "$MAPS/demo-city-wgs84/manifest.json" <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))
m["name"] = "demo-city-wgs84"
m["geo"] = {"origin_lat_deg": 49.58, "origin_lon_deg": 6.08,
            "crs": "demo-city placed near Luxembourg for the web view's exports"}
json.dump(m, open(sys.argv[2], "w"), indent=1)
PY
fi

workdir=$(mktemp -d)
server_pid=""
web_pid=""
cleanup() {
  for pid in "$web_pid" "$server_pid"; do
    if [ -n "$pid" ] && kill -0 "$pid" 2>/dev/null; then
      kill -TERM "$pid" 2>/dev/null || true
      wait "$pid" 2>/dev/null || true
    fi
  done
  rm -rf "$workdir"
}
trap cleanup EXIT
trap 'exit 0' INT TERM

# Each program prints one readiness line on stdout once it serves; read it
# through a FIFO kept open for the program's lifetime.
mkfifo "$workdir/server" "$workdir/web"
"$BIN/riskplan-server" --listen=127.0.0.1:0 --maps="$MAPS" --rpc_log=false \
  2>"$OUT/web-server.log" >"$workdir/server" &
server_pid=$!
exec 3<"$workdir/server"
if ! read -r -t 120 line <&3 || [[ "$line" != "riskplan-server listening on "* ]]; then
  echo "run-web: riskplan-server did not start; its log:" >&2
  cat "$OUT/web-server.log" >&2
  exit 1
fi
SERVER=${line#riskplan-server listening on }

"$BIN/riskplan-web" --listen="$LISTEN" --server="$SERVER" "$@" \
  2>"$OUT/web-gateway.log" >"$workdir/web" &
web_pid=$!
exec 4<"$workdir/web"
if ! read -r -t 60 line <&4 || [[ "$line" != "riskplan-web listening on "* ]]; then
  echo "run-web: riskplan-web did not start; its log:" >&2
  cat "$OUT/web-gateway.log" >&2
  exit 1
fi
WEB=${line#riskplan-web listening on }
echo "riskplan-server on demo-city and demo-city-wgs84 at $SERVER (log: $OUT/web-server.log)"
echo "riskplan-web at $WEB (log: $OUT/web-gateway.log)"
echo
echo "open http://$WEB/  (Ctrl-C stops both)"
wait "$web_pid"
