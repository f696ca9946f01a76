#!/usr/bin/env bash
# The whole test suite: installs what it needs (the build's packages plus
# Verilator for the RTL of the FPGA component), builds, and runs every test
# through CTest. Exits non-zero when anything fails.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh verilator
# The RTL backend is asked for explicitly, so that a build directory
# configured before Verilator was installed does not skip its tests.
bash scripts/build.sh -DRISKPLAN_WITH_VERILATOR=ON
BUILD_DIR=${BUILD_DIR:-build}
ctest --test-dir "$BUILD_DIR" --output-on-failure -j "$(nproc)" --timeout 900 --no-tests=error
