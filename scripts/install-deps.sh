#!/usr/bin/env bash
# Installs every Debian package camlab builds, tests and benchmarks with.
# Idempotent: when everything is already installed it prints one line and exits 0.
set -euo pipefail

packages=(
  build-essential cmake pkg-config git
  lld                    # the linker CMakeLists.txt uses when present: links in a fraction of GNU ld's time
  clang-format           # scripts/check-format.sh (Debian 12: version 14, the one .clang-format is checked with)
  clang-14 libclang-rt-14-dev   # scripts/fuzz.sh: clang++ and its libFuzzer and sanitizer runtimes
  libopencv-dev          # image I/O, chessboard detection, filtering
  libopencv-contrib-dev  # cv::aruco: ArUco dictionaries, ChArUco detection (calib/corners/charuco_corners.h)
  libturbojpeg0-dev      # MJPEG frames: decode (3x OpenCV's imdecode) and the virtual camera's encoder
  libdeflate-dev         # PNG frames: the capture writer's deflate, 5-7x zlib's time at the same size (docs/BENCHMARKS.md)
  zlib1g-dev             # the PNG encoder's test inflates its output with zlib, an independent decoder
  libmrcal-dev mrcal python3-mrcal   # lens models (C API) and mrcal's own tools for interop tests
  libmrgingham-dev       # mrcal's chessboard detector (square boards), calib/corners/mrgingham_corners.h
  gnuplot-qt             # draws every plot (analysis/plot.h; pngcairo, no display needed); mrcal's tools pull it in too
  libboost-dev           # Beast / Asio (header-only parts)
  nlohmann-json3-dev libcli11-dev libspdlog-dev libsqlite3-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  v4l-utils              # v4l2-ctl and v4l2-compliance: unmodified clients of the virtual camera
  ffmpeg                 # and ffmpeg's v4l2 input, reading the colour camera's Bayer and MJPEG frames
  gstreamer1.0-tools gstreamer1.0-plugins-good   # gst-launch-1.0 and v4l2src (video/x-bayer, image/jpeg caps)
  # More unmodified V4L2 clients of the virtual camera (tests/integration/vcam_clients_test,
  # vcam_yuyv_range_test): each finds the camera its own way and captures from it.
  ustreamer motion fswebcam uvccapture
  gstreamer1.0-plugins-base-apps   # gst-device-monitor-1.0
  gstreamer1.0-libcamera # libcamera's GStreamer provider, as camera users have it: the monitor's test runs with and without it
  libcamera-dev libcamera-tools   # the libcamera backend (0.0.3), and cam to test it against the virtual camera
  wrk curl               # camlabd: status-request load benchmark (tests/bench/service_bench), README's curl session
  chromium               # the dashboard's browser test (tests/browser), headless
  # Fleets of camlabd hosts on a shared PostgreSQL job store (docs/fleet.md): libpqxx for
  # camlabd's PostgreSQL store, and the server (initdb, pg_ctl, postgres, psql under
  # /usr/lib/postgresql/15/bin) for the tests and benchmarks, which start throwaway
  # clusters of their own (Debian also makes its own "main" cluster; camlab never uses it).
  libpqxx-dev postgresql-15
  systemd python3-yaml   # tests/architecture/check_deploy.py: systemd-analyze verify of deploy/systemd/camlabd.service, the DaemonSet's YAML
)
# node and npm run the browser test's driver (playwright-core, installed by the build with npm
# ci). A machine that has them already (e.g. NodeSource's nodejs, which brings its own npm)
# keeps them: Debian's npm package would pull Debian's nodejs over it.
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
  packages+=(nodejs npm)
fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages already installed"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done"
