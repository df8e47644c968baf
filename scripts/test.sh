#!/usr/bin/env bash
# Installs dependencies, builds everything and runs the full test suite with ctest.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build="${PCL_MI_BUILD_DIR:-$root/build}"
bash "$root/scripts/setup_debian.sh"
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release
cmake --build "$build" -j "$(nproc)"
cd "$build"
# PoCL is installed above, so the OpenCL tests must run here, not skip.
export PCL_MI_REQUIRE_OPENCL=1
ctest --output-on-failure -j "$(nproc)"
