// The virtual V4L2 device's first-frame latency and frame pacing (docs/measuring.md).
//
//   vcam_latency_bench [--quick]
//
// For the default camera (640x480) and the 1280x800 example camera, each with its
// example scene, paced in real time and driven through the device's ioctls in process
// (what the broker does for `camlab vcam run`), YUYV at the sensor's size:
//   - cold: STREAMON to the first buffer done, on the device's first stream (the scene
//     integral is computed then), and the sequence numbers lost after it (a slow first
//     frame must delay the stream, not open a gap in it);
//   - warm: the same on later streams, STREAMON half a second after STREAMOFF (the
//     integral is reused; a new client of a camera that has rendered before, or one that
//     retries after a timeout);
//   - restart: STREAMON right after STREAMOFF of a running stream: the frame that was
//     rendering when the stream stopped is finished first, so this is the worst case;
//   - steady: the mean period between frames and the frames lost (sequence gaps) over a
//     stream of 60 frames.
// Latencies are compared with the frame interval: the bar is a warm first frame within
// one interval.
#include <linux/videodev2.h>
#include <poll.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <thread>
#include <vector>

#include "mock_device/spec/default_specs.h"
#include "mock_device/v4l2/virtual_v4l2_device.h"

namespace {

using namespace camlab;
using namespace camlab::mock;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

const fs::path kExamples = fs::path(CAMLAB_SOURCE_DIR) / "mock_device/examples";
constexpr int kBuffers = 4;

void check(int result, const char* what) {
  if (result != 0) {
    std::fprintf(stderr, "%s: %s\n", what, std::strerror(-result));
    std::exit(1);
  }
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

struct Stream {
  VirtualV4l2Device& device;
  int file;

  void queue_all() {
    for (int i = 0; i < kBuffers; ++i) {
      v4l2_buffer b{};
      b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      b.memory = V4L2_MEMORY_MMAP;
      b.index = static_cast<uint32_t>(i);
      check(device.ioctl(file, VIDIOC_QBUF, &b), "QBUF");
    }
  }
  // Blocks until a buffer is done (at most 60 s), dequeues it.
  v4l2_buffer dequeue() {
    if (!(device.wait_events(file, POLLIN, 60000) & POLLIN)) {
      std::fprintf(stderr, "no frame within 60 s\n");
      std::exit(1);
    }
    v4l2_buffer b{};
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = V4L2_MEMORY_MMAP;
    check(device.ioctl(file, VIDIOC_DQBUF, &b), "DQBUF");
    return b;
  }
  // STREAMON to the first buffer done, in ms; leaves the stream on.
  double first_frame_ms() {
    queue_all();
    int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    const auto start = Clock::now();
    check(device.ioctl(file, VIDIOC_STREAMON, &type), "STREAMON");
    (void)dequeue();
    return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  }
  void stop() {
    int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    check(device.ioctl(file, VIDIOC_STREAMOFF, &type), "STREAMOFF");
  }
};

void run_camera(const char* label, CameraSpec camera, SceneSpec scene, int warm_repeats) {
  const double interval_ms = camera.timing.frame_interval_us * 1e-3;
  auto created = VirtualV4l2Device::create(std::move(camera), std::move(scene), {});
  if (!created) {
    std::fprintf(stderr, "%s\n", created.error().message.c_str());
    std::exit(1);
  }
  VirtualV4l2Device& device = **created;
  const int file = device.open_file(false);
  v4l2_format format{};
  format.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  check(device.ioctl(file, VIDIOC_G_FMT, &format), "G_FMT");
  format.fmt.pix.pixelformat = V4L2_PIX_FMT_YUYV;
  check(device.ioctl(file, VIDIOC_S_FMT, &format), "S_FMT");
  v4l2_requestbuffers request{};
  request.count = kBuffers;
  request.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  request.memory = V4L2_MEMORY_MMAP;
  check(device.ioctl(file, VIDIOC_REQBUFS, &request), "REQBUFS");

  Stream stream{device, file};
  const double cold_ms = stream.first_frame_ms();
  const uint32_t cold_gap = stream.dequeue().sequence - 1;  // the frame after sequence 0
  stream.stop();
  std::vector<double> warm, restart;
  for (int i = 0; i < warm_repeats; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    warm.push_back(stream.first_frame_ms());
    // A few frames, then at once a new stream.
    for (int frame = 0; frame < 3; ++frame) {
      v4l2_buffer b = stream.dequeue();
      check(device.ioctl(file, VIDIOC_QBUF, &b), "QBUF");
    }
    stream.stop();
    restart.push_back(stream.first_frame_ms());
    stream.stop();
  }

  // Steady state: 60 frames, each buffer re-queued as soon as it is dequeued.
  (void)stream.first_frame_ms();
  constexpr int kFrames = 60;
  const auto start = Clock::now();
  uint32_t first_sequence = 0, last_sequence = 0;
  for (int i = 0; i < kFrames; ++i) {
    v4l2_buffer b = stream.dequeue();
    if (i == 0) first_sequence = b.sequence;
    last_sequence = b.sequence;
    check(device.ioctl(file, VIDIOC_QBUF, &b), "QBUF");
  }
  const double period_ms =
      std::chrono::duration<double, std::milli>(Clock::now() - start).count() / (kFrames - 1);
  const uint32_t lost = last_sequence - first_sequence + 1 - kFrames;
  stream.stop();
  device.close_file(file);

  std::printf("| %s | %.1f | %.0f | %u | %.1f | %.1f | %.2f | %.1f | %.1f | %u |\n", label,
              interval_ms, cold_ms, cold_gap, median(warm),
              *std::max_element(warm.begin(), warm.end()), median(warm) / interval_ms,
              median(restart), period_ms, lost);
}

}  // namespace

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::strcmp(argv[1], "--quick") == 0;
  const int warm_repeats = quick ? 5 : 20;
  std::printf(
      "Virtual V4L2 device, YUYV, paced: STREAMON to the first frame (cold: integral computed; "
      "warm: 0.5 s after a stream, median and max of %d; restart: at once, median), then 60 "
      "frames\n",
      warm_repeats);
  std::printf(
      "| camera | interval ms | cold first frame ms | frames lost after it | warm first frame ms | "
      "warm max ms | warm / interval | restart first frame ms | steady period ms | frames lost "
      "in 60 |\n|---|---|---|---|---|---|---|---|---|---|\n");
  run_camera("640x480 (default camera and scene)", default_camera_spec(), default_scene_spec(),
             warm_repeats);
  auto wide = load_camera_spec(kExamples / "camera_wide_1280x800.json");
  auto chessboard = load_scene_spec(kExamples / "scene_chessboard_calibration.json");
  if (!wide || !chessboard) {
    std::fprintf(stderr, "cannot load the 1280x800 example specs\n");
    return 1;
  }
  run_camera("1280x800 (chessboard scene)", std::move(*wide), std::move(*chessboard), warm_repeats);
  return 0;
}
