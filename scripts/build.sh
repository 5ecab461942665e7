#!/usr/bin/env bash
# Installs the Debian packages camlab needs (idempotent), then configures and builds it
# in ./build (or $CAMLAB_BUILD_DIR). Extra arguments go to `cmake --build`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
build_dir="${CAMLAB_BUILD_DIR:-build}"
cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build "$build_dir" -j "$(nproc)" "$@"
