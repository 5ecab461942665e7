// Capture through camlab's V4L2 backend against v4l2-ctl, on the same virtual device in
// the same run: frames per second and CPU time per frame.
//
//   capture_bench [--frames N]            runs both under `camlab vcam run` and prints
//   capture_bench --child N               (internal) the camlab side: N frames via V4l2Camera
//
// Both clients stream GREY 640x480 MMAP from the default virtual camera. The device
// renders in the broker (the `camlab vcam run` process), so the client's own CPU per
// frame (measured with the shell's `times` around the client alone) is its cost of
// capturing: ioctls, waiting, touching the frame. Total CPU includes the rendering.
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "device/v4l2/v4l2_camera.h"

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
  double total_cpu_s = 0;    // broker (rendering) + client
  double client_cpu_s = -1;  // the client process alone (from `times`)
  int status = -1;
};

// Parses the children's line of sh's `times` ("0m0.123s 0m0.045s"): user + system.
double parse_times_children(const std::string& output) {
  const auto line_start = output.rfind('\n', output.size() >= 2 ? output.size() - 2 : 0);
  const std::string line = output.substr(line_start == std::string::npos ? 0 : line_start + 1);
  int um = 0, sm = 0;
  double us = 0, ss = 0;
  if (std::sscanf(line.c_str(), "%dm%lfs %dm%lfs", &um, &us, &sm, &ss) != 4) return -1;
  return um * 60 + us + sm * 60 + ss;
}

Measured measure(const std::string& command) {
  rusage before{}, after{};
  getrusage(RUSAGE_CHILDREN, &before);
  const auto start = std::chrono::steady_clock::now();
  Measured m;
  std::string output;
  if (FILE* pipe = popen(command.c_str(), "r")) {
    char buffer[4096];
    for (size_t n; (n = fread(buffer, 1, sizeof buffer, pipe)) > 0;) output.append(buffer, n);
    const int status = pclose(pipe);
    m.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  m.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  getrusage(RUSAGE_CHILDREN, &after);
  auto seconds = [](const timeval& t) { return t.tv_sec + t.tv_usec * 1e-6; };
  m.total_cpu_s = seconds(after.ru_utime) - seconds(before.ru_utime) + seconds(after.ru_stime) -
                  seconds(before.ru_stime);
  m.client_cpu_s = parse_times_children(output);
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
  std::printf("Capture of %d GREY 640x480 frames from the default virtual camera (30 fps clock)\n",
              frames);
  std::printf(
      "| client | wall s | frames/s | client CPU ms/frame | total CPU ms/frame (with rendering) |\n"
      "|---|---|---|---|---|\n");
  const struct {
    const char* name;
    std::string command;
  } clients[] = {
      {"camlab V4l2Camera", vcam + "sh -c '" + self + " --child " + count + " && times'"},
      {"v4l2-ctl --stream-mmap",
       vcam +
           "sh -c 'v4l2-ctl -d /dev/video0 --set-fmt-video=pixelformat=GREY,width=640,"
           "height=480 --stream-mmap --stream-count=" +
           count + " --stream-to=/dev/null > /dev/null 2>&1 && times'"},
  };
  for (const auto& c : clients) {
    const Measured m = measure(c.command);
    if (m.status != 0) {
      std::printf("| %s | failed (status %d) | | | |\n", c.name, m.status);
      continue;
    }
    std::printf("| %s | %.2f | %.1f | %.3f | %.2f |\n", c.name, m.wall_s, frames / m.wall_s,
                1e3 * m.client_cpu_s / frames, 1e3 * m.total_cpu_s / frames);
  }
  return 0;
}
