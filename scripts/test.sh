#!/usr/bin/env bash
# The whole test suite: installs what it needs (the build's packages plus
# Verilator for the RTL of the FPGA component), builds, and runs every test
# through CTest; then the sanitizer passes (scripts/sanitize.sh: the suite
# under ASan + UBSan, the fuzz targets' smoke, the accel tests under TSan).
# RISKPLAN_SANITIZERS=0 skips the sanitizer passes. Exits non-zero when
# anything fails.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh verilator
# The RTL backend is asked for explicitly, so that a build directory
# configured before Verilator was installed does not skip its tests.
bash scripts/build.sh -DRISKPLAN_WITH_VERILATOR=ON
BUILD_DIR=${BUILD_DIR:-build}
ctest --test-dir "$BUILD_DIR" --output-on-failure -j "$(nproc)" --timeout 900 --no-tests=error
if [ "${RISKPLAN_SANITIZERS:-1}" != 0 ]; then
  bash scripts/sanitize.sh
fi
