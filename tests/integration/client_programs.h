// Running other programs against the virtual camera in tests: a camera and scene that
// every V4L2 client can stream (640x480 YUYV, 30 frames/s, noise-free so the renderer's
// image is the truth), that truth image, commands with a time limit, programs that run
// until stopped (killed with their whole process group), a loopback HTTP GET, and the
// comparison of a client's image with the truth.
#pragma once

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "cli_runner.h"

namespace camlab::testing {

namespace fs = std::filesystem;

// 640x480, 10 bits, black level 16 DN, no noise; a pinhole 8 mm lens and a slanted edge
// at 50 m (dark 0.1, light 0.7 reflectance), so the lens is not sampled and the first
// frame is quick. At 540 lux the 8-bit image is about 32 DN left of the edge and 199
// right of it, mean 115: near 113, where every YUYV range convention (full range, or
// limited range read as either) gives the same mean within 1 DN.
inline const char* kClientCameraJson = R"({
  "name": "vcam clients test",
  "sensor": {"width_px": 640, "height_px": 480, "pixel_pitch_um": 4.0, "bit_depth": 10,
             "black_level_dn": 16, "full_well_e": 12000, "read_noise_e": 0, "shot_noise": false},
  "lens": {"focal_mm": 8.0, "f_number_min": 2.0, "f_number_max": 16.0},
  "timing": {"frame_interval_us": 33333},
  "controls": {"exposure_time_absolute": {"min": 1, "max": 333, "default": 100}}})";
inline const char* kClientSceneJson = R"({
  "illuminance_lux": 540,
  "targets": [{"type": "slanted_edge", "size_m": [60, 60], "angle_deg": 5,
               "dark_reflectance": 0.1, "light_reflectance": 0.7,
               "pose": {"position_m": [0, 0, 50.0]}}]})";

// Means of an 8-bit image over the top 80% of its rows (motion stamps the time in the
// bottom corner): the whole width, the left third (dark) and the right third (light).
struct ImageMeans {
  double all = 0, dark = 0, light = 0;
};

inline ImageMeans means_of(const cv::Mat& grey) {
  const int rows = grey.rows * 8 / 10, third = grey.cols / 3;
  ImageMeans m;
  m.all = cv::mean(grey(cv::Rect(0, 0, grey.cols, rows)))[0];
  m.dark = cv::mean(grey(cv::Rect(0, 0, third, rows)))[0];
  m.light = cv::mean(grey(cv::Rect(grey.cols - third, 0, third, rows)))[0];
  return m;
}

// The renderer's noise-free frame for the client camera (`camlab render --no-noise`), as
// the 8-bit values the virtual device's GREY and YUYV carry (DN / 4 for 10 bits).
inline cv::Mat truth_image(const fs::path& dir) {
  auto run = run_cli("render --camera " + (dir / "camera.json").string() + " --scene " +
                     (dir / "scene.json").string() + " --no-noise --quiet --out " +
                     (dir / "truth").string());
  if (run.exit_code != 0) return {};
  cv::Mat dn = cv::imread((dir / "truth/frame_000000.png").string(), cv::IMREAD_UNCHANGED);
  if (dn.empty()) return {};
  cv::Mat y8;
  dn.convertTo(y8, CV_64F, 1.0 / 4);
  return y8;
}

// Whether a client's picture is the camera's image: the same size ratio, a mean within
// 4 DN of the truth's (JPEG and any YUYV range convention, see kClientSceneJson), and
// the edge's contrast within 20% (a range conversion scales it by 0.86 to 1.16).
inline ::testing::AssertionResult is_the_cameras_image(const cv::Mat& picture,
                                                       const cv::Mat& truth) {
  if (picture.empty()) return ::testing::AssertionFailure() << "the picture does not decode";
  if (truth.empty()) return ::testing::AssertionFailure() << "no truth image";
  if (picture.cols * truth.rows != picture.rows * truth.cols)
    return ::testing::AssertionFailure() << "size " << picture.cols << "x" << picture.rows;
  cv::Mat grey;
  if (picture.channels() == 3)
    cv::cvtColor(picture, grey, cv::COLOR_BGR2GRAY);
  else
    grey = picture;
  const ImageMeans got = means_of(grey), want = means_of(truth);
  const double contrast = got.light - got.dark, truth_contrast = want.light - want.dark;
  if (std::fabs(got.all - want.all) > 4 || std::fabs(contrast / truth_contrast - 1) > 0.2)
    return ::testing::AssertionFailure()
           << "mean " << got.all << " (truth " << want.all << "), dark " << got.dark << " light "
           << got.light << " (truth " << want.dark << ", " << want.light << ")";
  return ::testing::AssertionSuccess() << "mean " << got.all << " (truth " << want.all << ")";
}

// A loopback TCP port nothing listens on now.
inline int free_loopback_port() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t length = sizeof address;
  int port = 0;
  if (bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0 &&
      getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) == 0)
    port = ntohs(address.sin_port);
  close(fd);
  return port;
}

struct HttpReply {
  int status = 0;
  std::string body;
};

// GET http://127.0.0.1:port/path with HTTP/1.0, at most `timeout` for the whole exchange.
inline std::optional<HttpReply> http_get(int port, const std::string& path,
                                         std::chrono::milliseconds timeout) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return std::nullopt;
  timeval limit{static_cast<time_t>(timeout.count() / 1000),
                static_cast<suseconds_t>(timeout.count() % 1000 * 1000)};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &limit, sizeof limit);
  setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &limit, sizeof limit);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  std::string raw;
  if (connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0) {
    const std::string request = "GET " + path + " HTTP/1.0\r\nHost: 127.0.0.1\r\n\r\n";
    if (send(fd, request.data(), request.size(), MSG_NOSIGNAL) ==
        static_cast<ssize_t>(request.size())) {
      char buffer[65536];
      for (ssize_t n; raw.size() < (64u << 20) && (n = recv(fd, buffer, sizeof buffer, 0)) > 0;)
        raw.append(buffer, static_cast<size_t>(n));
    }
  }
  close(fd);
  const size_t header_end = raw.find("\r\n\r\n");
  if (raw.compare(0, 9, "HTTP/1.0 ") != 0 && raw.compare(0, 9, "HTTP/1.1 ") != 0)
    return std::nullopt;
  if (header_end == std::string::npos) return std::nullopt;
  HttpReply reply;
  reply.status = std::atoi(raw.c_str() + 9);
  reply.body = raw.substr(header_end + 4);
  return reply;
}

// A command that runs until stopped (`camlab vcam run -- PROGRAM ...`), in its own
// process group with its output in `log`; stopped (SIGTERM to the group, then SIGKILL
// after 10 s) when the object goes.
class BackgroundProgram {
 public:
  BackgroundProgram(const std::vector<std::string>& argv, const fs::path& log) {
    pid_ = fork();
    if (pid_ == 0) {
      setpgid(0, 0);
      const int out = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      if (out >= 0) {
        dup2(out, 1);
        dup2(out, 2);
      }
      std::vector<char*> raw;
      for (const auto& a : argv) raw.push_back(const_cast<char*>(a.c_str()));
      raw.push_back(nullptr);
      execv(raw[0], raw.data());
      _exit(127);
    }
    if (pid_ > 0) setpgid(pid_, pid_);  // no race with the child's own setpgid
  }
  BackgroundProgram(const BackgroundProgram&) = delete;
  BackgroundProgram& operator=(const BackgroundProgram&) = delete;
  ~BackgroundProgram() { stop(); }

  bool running() {
    if (pid_ <= 0) return false;
    int status = 0;
    if (waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      return false;
    }
    return true;
  }

  // SIGTERM to the group (camlab passes it on; motion and ustreamer exit on it), SIGKILL
  // to whatever is left after 10 s.
  void stop() {
    if (pid_ <= 0) return;
    kill(-pid_, SIGTERM);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (running() && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    if (pid_ > 0) {
      kill(-pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
      pid_ = -1;
    }
  }

 private:
  pid_t pid_ = -1;
};

// Polls `ready` every 200 ms until it returns true or `limit` passes.
template <class Ready>
bool wait_for(std::chrono::seconds limit, Ready ready) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < deadline) {
    if (ready()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  return ready();
}

inline std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

}  // namespace camlab::testing
