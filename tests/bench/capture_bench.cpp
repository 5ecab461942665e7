// Capture through camlab's V4L2 backend against v4l2-ctl, on the same virtual device in
// the same run (device issue): frames per second and CPU time per frame.
//
//   capture_bench [--frames N]            runs both under `camlab vcam run` and prints
//   capture_bench --child N               (internal) the camlab side: N frames via V4l2Camera
//
// Both clients stream GREY 640x480 MMAP from the default virtual camera; the device
// renders inside each client process (preload), so CPU per frame includes rendering for
// both, and the difference is the client's own cost (copies, conversions).
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "device/v4l2_camera.h"

namespace {

using namespace std::chrono_literals;

int run_child(int frames) {
  auto camera = camlab::device::V4l2Camera::open(camlab::device::system_v4l2_io(), "/dev/video0");
  if (!camera) {
    std::fprintf(stderr, "%s\n", camera.error().message.c_str());
    return 1;
  }
  if (auto f = (*camera)->configure({"GREY", 640, 480}); !f) return 1;
  if (!(*camera)->start(4)) return 1;
  volatile uint64_t checksum = 0;  // touch every frame once, as a consumer would
  for (int i = 0; i < frames; ++i) {
    auto frame = (*camera)->dequeue(5000ms);
    if (!frame) {
      std::fprintf(stderr, "%s\n", frame.error().message.c_str());
      return 1;
    }
    checksum = checksum + frame->data[frame->size / 2];
    if (!(*camera)->requeue(*frame)) return 1;
  }
  return (*camera)->stop() ? 0 : 1;
}

struct Measured {
  double wall_s = 0;
  double cpu_s = 0;
  int status = -1;
};

Measured measure(const std::string& command) {
  rusage before{}, after{};
  getrusage(RUSAGE_CHILDREN, &before);
  const auto start = std::chrono::steady_clock::now();
  Measured m;
  m.status = std::system(command.c_str());
  m.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  getrusage(RUSAGE_CHILDREN, &after);
  auto seconds = [](const timeval& t) { return t.tv_sec + t.tv_usec * 1e-6; };
  m.cpu_s = seconds(after.ru_utime) - seconds(before.ru_utime) + seconds(after.ru_stime) - seconds(before.ru_stime);
  return m;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 3 && std::strcmp(argv[1], "--child") == 0) return run_child(std::atoi(argv[2]));
  int frames = 120;
  if (argc == 3 && std::strcmp(argv[1], "--frames") == 0) frames = std::atoi(argv[2]);
  char self[4096];
  const ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
  if (n <= 0) return 1;
  self[n] = '\0';
  const std::string vcam = std::string(CAMLAB_CLI_PATH) + " vcam run -- ";
  const std::string count = std::to_string(frames);
  std::printf("Capture of %d GREY 640x480 frames from the default virtual camera (30 fps clock)\n", frames);
  std::printf("| client | wall s | frames/s | CPU ms/frame |\n|---|---|---|---|\n");
  const struct {
    const char* name;
    std::string command;
  } clients[] = {
      {"camlab V4l2Camera", vcam + self + " --child " + count},
      {"v4l2-ctl --stream-mmap", vcam + "v4l2-ctl -d /dev/video0 --set-fmt-video=pixelformat=GREY,width=640,height=480"
                                        " --stream-mmap --stream-count=" + count + " --stream-to=/dev/null > /dev/null 2>&1"},
  };
  for (const auto& c : clients) {
    const Measured m = measure(c.command);
    if (m.status != 0) {
      std::printf("| %s | failed (status %d) | | |\n", c.name, m.status);
      continue;
    }
    std::printf("| %s | %.2f | %.1f | %.2f |\n", c.name, m.wall_s, frames / m.wall_s, 1e3 * m.cpu_s / frames);
  }
  return 0;
}
