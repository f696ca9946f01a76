#!/usr/bin/env bash
# The README's main job: builds riskplan if needed, then evaluates a sample
# trajectory across the built-in demo-city and prints its risk, length and
# admissibility. Extra arguments are passed to `riskplan-tool evaluate`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh >&2
BIN=${BUILD_DIR:-build}/bin
# South-west suburbs to north-east suburbs, 250 m AMSL, through the centre.
WAYPOINTS=${WAYPOINTS:-"1200,1500,250,0.785; 4000,4000,250,0.785; 6800,6500,250,0.785"}
echo "== riskplan-tool evaluate on demo-city =="
"$BIN/riskplan-tool" evaluate --waypoints="$WAYPOINTS" "$@"
