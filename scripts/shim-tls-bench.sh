#!/usr/bin/env bash
# What TLS costs on the FPGA shim link (docs/benchmarks.md, "TLS"): the
# in-process model shim of riskplan-bench-shim, its batches and its
# connections, plaintext and over mutual TLS, in one run. Certificates come
# from tests/integration/test_pki.sh (made here, thrown away).
#
#   scripts/shim-tls-bench.sh [EXTRA GOOGLE BENCHMARK FLAGS]
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BUILD_DIR:-build}/bin
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
from=$(date -u -d '-1 hour' +%Y%m%d%H%M%SZ)
until=$(date -u -d '+1 day' +%Y%m%d%H%M%SZ)
bash tests/integration/test_pki.sh init "$work"
bash tests/integration/test_pki.sh issue "$work" shim a board "IP:127.0.0.1" server "$from" "$until"
bash tests/integration/test_pki.sh issue "$work" client a riskplan-server "" client "$from" "$until"
"$BIN/riskplan-bench-shim" --tls_dir="$work" \
  --benchmark_filter='BM_ShimConnect|BM_ShimBatch/batch:(256|4096|65536)/along:1/mmio:0' \
  --benchmark_repetitions=5 --benchmark_report_aggregates_only=true "$@"
