#!/usr/bin/env bash
# The README's test command: on a fresh Debian 12 machine, installs what camlab needs,
# builds everything and runs every test (unit, integration) through ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
build_dir="${CAMLAB_BUILD_DIR:-build}"
# The fuzz harnesses' clang build is a build too: done here on every core, so that the
# ctest test fuzz_harnesses only fuzzes.
CAMLAB_FUZZ_BUILD_DIR="$build_dir/fuzz" bash scripts/fuzz.sh --build-only
# Two jobs a core: with one, a quarter of the CPU sat idle while the camera and service
# tests waited on frame clocks, sockets and child processes; with one more than cores,
# still some (2 cores: 230 s at -j3, 215 s at -j4 on a warm tree with the same tests).
# The timing-sensitive tests hold beside three busy loops, the load -j4 puts on 2 cores.
ctest --test-dir "$build_dir" --output-on-failure -j "$(( $(nproc) * 2 ))" --timeout 600
