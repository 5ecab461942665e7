#!/usr/bin/env bash
# `camlab vcam run` feeding two unmodified clients, ffmpeg and OpenCV's VideoCapture:
# the frames/s each receives over N frames and the frames the camera skipped, read from
# the buffers' timestamps (a skipped frame is a step of two frame intervals or more).
#
#   tests/bench/vcam_client_rate_bench.sh [BUILD_DIR] [FRAMES] [CAMERA_JSON] [SCENE_JSON]
#
# Defaults: build, 300 frames, mock_device/examples/camera_640x480.json and
# scene_slanted_edges.json. Prints one Markdown table row per client. Needs ffmpeg and
# the vcam_opencv_rate_client target.
set -euo pipefail
source_dir=$(cd "$(dirname "$0")/../.." && pwd)
build_dir=${1:-build}
frames=${2:-300}
camera=${3:-$source_dir/mock_device/examples/camera_640x480.json}
scene=${4:-$source_dir/mock_device/examples/scene_slanted_edges.json}
camlab=$build_dir/cli/camlab
client=$build_dir/tests/bench/vcam_opencv_rate_client
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# The camera's size and frame interval, from its spec.
read -r width height interval_us < <(/usr/bin/python3 - "$camera" <<'PY'
import json, sys
c = json.load(open(sys.argv[1]))
s = c["sensor"]
print(s["width_px"], s["height_px"], c.get("timing", {}).get("frame_interval_us", 33333.3))
PY
)

# Reads "t_ms" lines; prints frames, span, frames/s, gaps and frames skipped.
summarise() {
  awk -v interval_ms="$(echo "$interval_us / 1000" | bc -l)" '
    { t = $1; if (n > 0) { d = t - p; if (d > 1.5 * interval_ms) { gaps++; skipped += int(d / interval_ms + 0.5) - 1 } }
      else f = t; p = t; n++ }
    END { span = (p - f) / 1000; printf "%d | %.2f | %.2f | %d | %d", n, span, (n - 1) / span, gaps, skipped }'
}

echo "| client | frames | span s | frames/s | gaps | frames skipped |"
echo "|---|---|---|---|---|---|"
"$camlab" vcam run --camera "$camera" --scene "$scene" -- \
  ffmpeg -hide_banner -nostdin -f v4l2 -input_format yuyv422 -video_size "${width}x$height" \
  -i /dev/video0 -frames:v "$frames" -vf showinfo -f null - >"$work/ffmpeg.log" 2>&1
echo "| ffmpeg (v4l2 demuxer, YUYV) | $(sed -nE 's/.*showinfo.* n: *[0-9]+ .*pts_time:([0-9.]+).*/\1/p' "$work/ffmpeg.log" |
  awk '{ printf "%.3f\n", $1 * 1000 }' | summarise) |"
"$camlab" vcam run --camera "$camera" --scene "$scene" -- \
  "$client" "$frames" "$width" "$height" >"$work/opencv.log"
echo "| OpenCV VideoCapture (CAP_V4L2, YUYV to BGR) | $(awk '/^frame/ { print $4 }' "$work/opencv.log" | summarise) |"
