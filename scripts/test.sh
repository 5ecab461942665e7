#!/usr/bin/env bash
# The README's test command: on a fresh Debian 12 machine, installs what camlab needs,
# builds everything and runs every test (unit, integration) through ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
build_dir="${CAMLAB_BUILD_DIR:-build}"
ctest --test-dir "$build_dir" --output-on-failure -j "$(nproc)" --timeout 600
