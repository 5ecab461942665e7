// Starts the built camlabd (CAMLABD_PATH) as a child process on an ephemeral loopback
// port with a temporary data folder, and talks HTTP/1.1 to it over plain sockets, so
// tests can also send malformed and oversized requests. Every wait is bounded.
#pragma once

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

extern char** environ;

namespace camlab::testing {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

struct HttpResult {
  int status = 0;                              // 0: no answer (connection refused, reset, timeout)
  std::map<std::string, std::string> headers;  // names lower-cased
  std::string body;
  nlohmann::json json() const { return nlohmann::json::parse(body, nullptr, false); }
  std::string error_code() const {
    auto j = json();
    return j.is_object() && j.contains("error") ? j["error"].value("code", "") : "";
  }
};

// A new TCP connection to 127.0.0.1:`port`, or -1. `receive_buffer` > 0 sets SO_RCVBUF
// first (a client that reads slowly, as the pressure benchmark's are).
inline int connect_loopback(int port, int receive_buffer = 0) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return -1;
  if (receive_buffer > 0)
    ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &receive_buffer, sizeof receive_buffer);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// Sends `bytes` on a new loopback connection to `port` and reads one response (headers,
// then Content-Length bytes); `timeout` bounds the whole exchange.
inline HttpResult raw_exchange(int port, const std::string& bytes,
                               std::chrono::milliseconds timeout = 10s) {
  HttpResult result;
  const int fd = connect_loopback(port);
  if (fd < 0) return result;
  timeval tv{static_cast<time_t>(timeout.count() / 1000),
             static_cast<suseconds_t>((timeout.count() % 1000) * 1000)};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
  size_t sent = 0;
  while (sent < bytes.size()) {
    const ssize_t n = ::send(fd, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) break;  // the server may answer and close before reading everything
    sent += static_cast<size_t>(n);
  }
  std::string in;
  char buffer[65536];
  size_t header_end = std::string::npos;
  size_t content_length = 0;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    const ssize_t n = ::recv(fd, buffer, sizeof buffer, 0);
    if (n <= 0) break;
    in.append(buffer, static_cast<size_t>(n));
    if (header_end == std::string::npos) {
      header_end = in.find("\r\n\r\n");
      if (header_end == std::string::npos) continue;
      std::istringstream lines(in.substr(0, header_end));
      std::string line;
      std::getline(lines, line);
      if (line.size() >= 12) result.status = std::atoi(line.substr(9, 3).c_str());
      while (std::getline(lines, line)) {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        const size_t colon = line.find(':');
        if (colon == std::string::npos) continue;
        std::string name = line.substr(0, colon);
        std::transform(name.begin(), name.end(), name.begin(), ::tolower);
        std::string value = line.substr(colon + 1);
        value.erase(0, value.find_first_not_of(' '));
        result.headers[name] = value;
      }
      content_length = std::strtoul(result.headers["content-length"].c_str(), nullptr, 10);
    }
    if (header_end != std::string::npos && in.size() >= header_end + 4 + content_length) break;
  }
  ::close(fd);
  if (header_end == std::string::npos) return HttpResult{};
  result.body = in.substr(header_end + 4, content_length);
  return result;
}

inline HttpResult http(int port, const std::string& method, const std::string& path,
                       const std::string& token = "", const std::string& body = "",
                       std::chrono::milliseconds timeout = 10s) {
  std::string request =
      method + " " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n";
  if (!token.empty()) request += "Authorization: Bearer " + token + "\r\n";
  if (!body.empty() || method == "POST" || method == "PUT")
    request +=
        "Content-Type: application/json\r\nContent-Length: " + std::to_string(body.size()) + "\r\n";
  request += "\r\n" + body;
  return raw_exchange(port, request, timeout);
}

// Percent-encodes a path segment (camera ids hold ':').
inline std::string url_segment(const std::string& s) {
  std::string out;
  char hex[4];
  for (unsigned char c : s) {
    if (std::isalnum(c) || c == '-' || c == '_' || c == '.' || c == '~') {
      out.push_back(static_cast<char>(c));
    } else {
      std::snprintf(hex, sizeof hex, "%%%02X", c);
      out += hex;
    }
  }
  return out;
}

inline std::string read_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// A camlabd child process. The data folder and log live in `dir`.
class Daemon {
 public:
  // `prefix`: a command that runs camlabd (e.g. {"camlab", "vcam", "run", "--"}); the
  // child is then put in its own process group so signals reach camlabd too.
  bool start(const fs::path& dir, std::vector<std::string> args,
             std::vector<std::string> prefix = {}) {
    dir_ = dir;
    fs::create_directories(dir);
    log_ = dir / ("camlabd." + std::to_string(++starts_) + ".log");
    std::vector<std::string> argv = prefix;
    argv.push_back(CAMLABD_PATH);
    argv.insert(argv.end(), {"--listen", "127.0.0.1:0", "--data", (dir / "data").string()});
    argv.insert(argv.end(), args.begin(), args.end());
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log_.c_str(),
                                     O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
    posix_spawnattr_t attr;
    posix_spawnattr_init(&attr);
    posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP);
    posix_spawnattr_setpgroup(&attr, 0);
    std::vector<char*> cargv;
    for (auto& a : argv) cargv.push_back(a.data());
    cargv.push_back(nullptr);
    const int rc = posix_spawn(&pid_, cargv[0], &actions, &attr, cargv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    posix_spawnattr_destroy(&attr);
    if (rc != 0) return false;
    // Bounded wait for the "listening on http://127.0.0.1:PORT" line.
    const std::string marker = "listening on http://127.0.0.1:";
    for (int i = 0; i < 600; ++i) {
      const std::string text = read_file(log_);
      if (auto at = text.find(marker); at != std::string::npos) {
        port_ = std::atoi(text.c_str() + at + marker.size());
        token_ = read_file(dir / "data" / "token");
        while (!token_.empty() && std::isspace(static_cast<unsigned char>(token_.back())))
          token_.pop_back();
        return port_ > 0 && !token_.empty();
      }
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        return false;
      }
      std::this_thread::sleep_for(50ms);
    }
    return false;
  }

  // Sends `sig` to the daemon's process group and waits (bounded) for the child; returns
  // its exit code, 128 + signal when killed, -1 on timeout.
  int stop(int sig = SIGTERM, std::chrono::seconds timeout = 30s) {
    if (pid_ <= 0) return -1;
    ::kill(-pid_, sig);
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    int status = 0;
    while (std::chrono::steady_clock::now() < deadline) {
      const pid_t r = waitpid(pid_, &status, WNOHANG);
      if (r == pid_) {
        pid_ = -1;
        // The whole group (camlabd under `vcam run`) is gone once the port refuses.
        for (int i = 0; i < 200 && http(port_, "GET", "/v1/health", "", "", 500ms).status != 0; ++i)
          std::this_thread::sleep_for(50ms);
        if (WIFEXITED(status)) return WEXITSTATUS(status);
        if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
        return -1;
      }
      std::this_thread::sleep_for(20ms);
    }
    append_thread_stacks();
    ::kill(-pid_, SIGKILL);
    waitpid(pid_, &status, 0);
    pid_ = -1;
    return -1;
  }

  ~Daemon() {
    if (pid_ > 0) stop(SIGKILL, 10s);
  }

  HttpResult get(const std::string& path) const { return http(port_, "GET", path, token_); }
  HttpResult post(const std::string& path, const nlohmann::json& body) const {
    return http(port_, "POST", path, token_, body.dump());
  }
  HttpResult put(const std::string& path, const nlohmann::json& body) const {
    return http(port_, "PUT", path, token_, body.dump());
  }
  HttpResult del(const std::string& path) const { return http(port_, "DELETE", path, token_); }

  // Polls GET /v1/jobs/{id} until `done(job)` (bounded); returns the last job JSON.
  template <class Pred>
  nlohmann::json wait_job(int64_t id, Pred done, std::chrono::seconds timeout = 120s) const {
    nlohmann::json job;
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      auto r = get("/v1/jobs/" + std::to_string(id));
      if (r.status == 200) {
        job = r.json();
        if (done(job)) return job;
      }
      std::this_thread::sleep_for(50ms);
    }
    return job;
  }
  nlohmann::json wait_finished(int64_t id, std::chrono::seconds timeout = 120s) const {
    return wait_job(
        id,
        [](const nlohmann::json& j) {
          const std::string s = j.value("state", "");
          return s != "queued" && s != "running";
        },
        timeout);
  }

  // The first camera's id (or the one whose transport contains `transport`).
  std::string camera_id(const std::string& transport = "") const {
    auto cameras = get("/v1/cameras").json();
    if (!cameras.is_object()) return "";
    for (const auto& c : cameras["cameras"])
      if (transport.empty() || c.value("transport", "").find(transport) != std::string::npos)
        return c.value("id", "");
    return "";
  }

  int port() const { return port_; }
  const std::string& token() const { return token_; }
  pid_t pid() const { return pid_; }
  std::string log() const { return read_file(log_); }

 private:
  // A daemon that does not stop is hung: where each of its threads waits goes into its log,
  // which the failing test prints (gdb when the machine has it; nothing otherwise).
  void append_thread_stacks() const {
    if (!fs::exists("/usr/bin/gdb")) return;
    const std::string command = "/usr/bin/gdb -q -batch -p " + std::to_string(pid_) +
                                " -ex 'thread apply all bt' >> '" + log_.string() +
                                "' 2>&1 < /dev/null";
    std::ofstream(log_, std::ios::app) << "\n--- camlabd did not stop: its threads ---\n";
    (void)std::system(command.c_str());
  }

  fs::path dir_, log_;
  pid_t pid_ = -1;
  int port_ = 0;
  int starts_ = 0;
  std::string token_;
};

inline fs::path fresh_test_dir(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("camlabd_test_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// A small noise-free camera (fast to render; exact signal levels), control latency 3.
inline const char* kTestCameraSpec = R"json({
  "name": "camlabd test camera 160x120",
  "sensor": {"width_px": 160, "height_px": 120, "pixel_pitch_um": 4.0, "bit_depth": 10, "black_level_dn": 32,
             "full_well_e": 12000, "read_noise_e": 0, "shot_noise": false, "quantum_efficiency": 0.65},
  "lens": {"focal_mm": 8.0, "f_number_min": 1.4, "f_number_max": 16.0,
           "iris": {"f_numbers": [16, 11, 8, 5.6, 4, 2.8, 2, 1.4]},
           "focus": {"position_min": 0, "position_max": 200, "extension_mm_per_step": 0.001}},
  "timing": {"frame_interval_us": 20000, "control_latency_frames": 3},
  "controls": {"exposure_time_absolute": {"min": 1, "max": 200, "default": 10},
               "gain": {"min": 100, "max": 800, "default": 100, "unity": 100},
               "focus_absolute": {"default": 50}, "iris_absolute": {"default": 5}}
})json";

// A slanted edge filling the view at 1.288 m, where focus position 50 is in focus
// (thin lens: 1/8 mm = 1/1288 mm + 1/(8 mm + 50 x 0.001 mm)).
inline const char* kTestSceneSpec = R"json({
  "name": "camlabd test scene", "illuminance_lux": 1200, "background_reflectance": 0.18,
  "targets": [{"type": "slanted_edge", "name": "edge", "size_m": [0.6, 0.6], "angle_deg": 5,
               "dark_reflectance": 0.2, "light_reflectance": 0.8,
               "pose": {"position_m": [0.0, 0.0, 1.288]}}]
})json";

inline void write_test_specs(const fs::path& dir) {
  std::ofstream(dir / "camera.json") << kTestCameraSpec;
  std::ofstream(dir / "scene.json") << kTestSceneSpec;
}

}  // namespace camlab::testing
