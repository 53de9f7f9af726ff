#!/usr/bin/env bash
# Builds vslam (installing what is missing) and runs the whole test suite.
#   tools/test.sh [ctest options...]
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh
cd build
ctest --output-on-failure -j "$(nproc 2>/dev/null || echo 2)" "$@"
