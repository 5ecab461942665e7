#!/usr/bin/env bash
# The README's main job: camlabd on its defaults. Installs what camlab needs, builds the
# daemon if needed, then execs it: http://127.0.0.1:8080, data in ./camlab-data (the
# SQLite database, capture folders, and the API token in camlab-data/token, never printed),
# every V4L2 camera found, or one in-process virtual camera when none is. Ctrl-C or
# SIGTERM stop it cleanly. Extra arguments go to camlabd (see `camlabd --help`).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh --target camlabd
build_dir="${CAMLAB_BUILD_DIR:-build}"
exec "$build_dir/service/camlabd" "$@"
