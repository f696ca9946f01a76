#!/usr/bin/env bash
# Configures (once) and builds riskplan into build/, every program in build/bin/.
# Extra arguments are passed to the CMake configure step.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
BUILD_DIR=${BUILD_DIR:-build}
if [ ! -f "$BUILD_DIR/build.ninja" ] || [ $# -gt 0 ]; then
  cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo "$@" >/dev/null
fi
# Two cores: keep the compile jobs bounded so gRPC's headers do not thrash memory.
cmake --build "$BUILD_DIR" -j "${RISKPLAN_JOBS:-$(nproc)}"
