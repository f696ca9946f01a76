#!/usr/bin/env bash
# The whole test suite: installs what it needs (the build's packages plus
# Verilator for the RTL of the FPGA component, and clang-14 for the sanitizer
# passes), builds, and runs every test through CTest; then the sanitizer passes
# (scripts/sanitize.sh: the suite under ASan + UBSan, the fuzz targets' smoke,
# the accel tests under TSan). RISKPLAN_SANITIZERS=0 skips the sanitizer
# passes. Exits non-zero when anything fails.
#
# While the normal suite runs, the ASan + UBSan build runs in the background
# (scripts/lib.sh's bg_build_start: nice 10, in the idle share of the cores).
set -euo pipefail
cd "$(dirname "$0")/.."
SANITIZERS=${RISKPLAN_SANITIZERS:-1}
extra=(verilator)
if [ "$SANITIZERS" != 0 ]; then extra+=(clang-14 libclang-rt-14-dev); fi
bash scripts/install-deps.sh "${extra[@]}"
# The RTL backend is asked for explicitly, so that a build directory
# configured before Verilator was installed does not skip its tests.
bash scripts/build.sh -DRISKPLAN_WITH_VERILATOR=ON
BUILD_DIR=${BUILD_DIR:-build}

source scripts/lib.sh
trap bg_build_stop EXIT
if [ "$SANITIZERS" != 0 ]; then bg_build_start asan; fi

ctest --test-dir "$BUILD_DIR" --output-on-failure -j "$(nproc)" --timeout 900 --no-tests=error

if [ "$SANITIZERS" != 0 ]; then
  bg_build_wait
  bash scripts/sanitize.sh
fi
