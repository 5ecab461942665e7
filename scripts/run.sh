#!/usr/bin/env bash
# The README's main job. Until camlabd lands (the daemon issue), the main job renders the
# virtual camera's example calibration set into ./camlab-data (a capture folder of
# chessboard views with their ground truth) and summarises what it wrote.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh --target camlab_cli
build_dir="${CAMLAB_BUILD_DIR:-build}"
out="camlab-data/render-$(date -u +%Y%m%dT%H%M%SZ)"
mkdir -p camlab-data
"$build_dir/cli/camlab" render \
  --camera mock_device/examples/camera_wide_1280x800.json \
  --scene mock_device/examples/scene_chessboard_calibration.json \
  --view 1 --view 3 --view 4 --view 5 \
  --out "$out" "$@"
echo "frames, sidecars (settings in effect + truth) and truth.cameramodel are in $out"
