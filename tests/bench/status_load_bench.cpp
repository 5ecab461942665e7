// camlabd status requests under load, idle and while a capture runs (docs/BENCHMARKS.md,
// "Status requests under load"): keep-alive HTTP/1.1 GET /v1/jobs/{id} of a finished job
// from N connections (16, 64, 256) on loopback for a bounded time, from one epoll client
// thread; requests/s, p50, p99, errors (non-200, 503 apart) and reconnects. Idle, then
// during a 300-frame `single` capture on the 640x480 example camera at 30 frames/s, and
// that capture's kept frames/s and wall time with the load against the same capture
// alone. Prints; never passes or fails.
//
//   status_load_bench [--seconds S] [--frames N] [--runs R] [--io-threads T] [--io-nice K]
//
// --io-threads and --io-nice are passed to camlabd (its defaults when not given).
//
// The client shares the machine's cores with camlabd: its own CPU is part of the load.
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "daemon_harness.h"

namespace {

using namespace camlab::testing;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

struct LoadResult {
  int connections = 0;
  double seconds = 0, requests_per_s = 0, p50_ms = 0, p99_ms = 0;
  long ok = 0, non_200 = 0, status_503 = 0, reconnects = 0;
};

struct Conn {
  int fd = -1;
  std::string in;
  size_t sent = 0;
  Clock::time_point t0;
};

int connect_nonblocking(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (fd < 0) return -1;
  const int one = 1;
  setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 && errno != EINPROGRESS) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// One complete response at the front of `in`: its length, status and whether the server
// closes after it; 0 while incomplete.
size_t parse_response(const std::string& in, int* status, bool* closes) {
  const size_t header_end = in.find("\r\n\r\n");
  if (header_end == std::string::npos) return 0;
  *status = in.size() > 12 ? std::atoi(in.c_str() + 9) : 0;
  std::string head = in.substr(0, header_end);
  std::transform(head.begin(), head.end(), head.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  size_t length = 0;
  if (auto at = head.find("content-length:"); at != std::string::npos)
    length = std::strtoul(head.c_str() + at + 15, nullptr, 10);
  *closes = head.find("connection: close") != std::string::npos;
  const size_t total = header_end + 4 + length;
  return in.size() >= total ? total : 0;
}

// N keep-alive connections, each sending the next GET once the previous answer is whole.
LoadResult load(int port, const std::string& token, const std::string& path, int connections,
                double seconds) {
  LoadResult result;
  result.connections = connections;
  const std::string request =
      "GET " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\nAuthorization: Bearer " + token + "\r\n\r\n";
  const int ep = ::epoll_create1(EPOLL_CLOEXEC);
  if (ep < 0) return result;
  std::vector<Conn> conns(connections);
  std::vector<double> latencies;
  latencies.reserve(1 << 20);
  auto open = [&](int i) {
    Conn& c = conns[i];
    if (c.fd >= 0) ::close(c.fd);
    c = Conn{};
    c.fd = connect_nonblocking(port);
    if (c.fd < 0) return;
    c.t0 = Clock::now();
    epoll_event ev{};
    ev.events = EPOLLIN | EPOLLOUT;
    ev.data.u32 = static_cast<uint32_t>(i);
    ::epoll_ctl(ep, EPOLL_CTL_ADD, c.fd, &ev);
  };
  auto want = [&](int i, uint32_t events) {
    epoll_event ev{};
    ev.events = events;
    ev.data.u32 = static_cast<uint32_t>(i);
    ::epoll_ctl(ep, EPOLL_CTL_MOD, conns[i].fd, &ev);
  };
  for (int i = 0; i < connections; ++i) open(i);
  const auto start = Clock::now();
  const auto end =
      start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  std::vector<epoll_event> events(std::max(connections, 1));
  char buffer[16384];
  while (Clock::now() < end) {
    const int n = ::epoll_wait(ep, events.data(), static_cast<int>(events.size()), 50);
    for (int k = 0; k < n; ++k) {
      const int i = static_cast<int>(events[k].data.u32);
      Conn& c = conns[i];
      if (c.fd < 0) continue;
      if (events[k].events & (EPOLLERR | EPOLLHUP) && !(events[k].events & EPOLLIN)) {
        ++result.reconnects;
        open(i);
        continue;
      }
      if (events[k].events & EPOLLOUT && c.sent < request.size()) {
        const ssize_t w =
            ::send(c.fd, request.data() + c.sent, request.size() - c.sent, MSG_NOSIGNAL);
        if (w < 0 && errno != EAGAIN) {
          ++result.reconnects;
          open(i);
          continue;
        }
        if (w > 0) c.sent += static_cast<size_t>(w);
        if (c.sent == request.size()) want(i, EPOLLIN);
      }
      if (!(events[k].events & EPOLLIN)) continue;
      bool closed = false;
      for (;;) {
        const ssize_t r = ::recv(c.fd, buffer, sizeof buffer, 0);
        if (r > 0) {
          c.in.append(buffer, static_cast<size_t>(r));
          continue;
        }
        closed = r == 0 || (errno != EAGAIN && errno != EWOULDBLOCK);
        break;
      }
      int status = 0;
      bool closes = false;
      if (const size_t used = parse_response(c.in, &status, &closes); used > 0) {
        const auto now = Clock::now();
        latencies.push_back(std::chrono::duration<double, std::milli>(now - c.t0).count());
        if (status == 200) {
          ++result.ok;
        } else {
          ++result.non_200;
          if (status == 503) ++result.status_503;
        }
        c.in.erase(0, used);
        if (closes || closed) {
          ++result.reconnects;
          open(i);
          continue;
        }
        c.sent = 0;
        c.t0 = now;
        want(i, EPOLLOUT);
      } else if (closed) {
        ++result.reconnects;
        open(i);
      }
    }
  }
  result.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  for (Conn& c : conns)
    if (c.fd >= 0) ::close(c.fd);
  ::close(ep);
  std::sort(latencies.begin(), latencies.end());
  result.requests_per_s = static_cast<double>(result.ok) / result.seconds;
  if (!latencies.empty()) {
    result.p50_ms = latencies[latencies.size() / 2];
    result.p99_ms = latencies[std::min(latencies.size() - 1, latencies.size() * 99 / 100)];
  }
  return result;
}

struct CaptureResult {
  std::string state;
  int kept = 0, dropped = 0;
  double wall_s = 0;
  double kept_per_s() const { return wall_s > 0 ? kept / wall_s : 0; }
};

// Posts a `frames`-frame single capture; `during` runs once it is running.
CaptureResult capture(const Daemon& daemon, const std::string& camera, int frames,
                      const std::function<void()>& during) {
  CaptureResult out;
  auto posted = daemon.post(camera + "/captures", {{"kind", "single"}, {"repeats", frames}});
  if (posted.status != 202) {
    out.state = "refused: " + posted.body;
    return out;
  }
  const int64_t id = posted.json()["id"];
  if (during) {
    daemon.wait_job(id, [](const json& j) { return j["state"] != "queued"; });
    during();
  }
  const json job = daemon.wait_finished(id, std::chrono::seconds(600));
  out.state = job.value("state", "?");
  if (job["result"].is_object()) {
    out.kept = job["result"].value("frames_kept", 0);
    out.dropped = job["result"].value("frames_dropped", 0);
    out.wall_s = job["result"].value("wall_seconds", 0.0);
  }
  return out;
}

void print_load(const char* condition, const LoadResult& r) {
  std::printf("| %s | %d | %.0f | %.2f | %.2f | %ld | %ld | %ld |\n", condition, r.connections,
              r.requests_per_s, r.p50_ms, r.p99_ms, r.non_200, r.status_503, r.reconnects);
  std::fflush(stdout);
}

void print_capture(const char* condition, const CaptureResult& c) {
  std::printf("| %s | %s | %d | %d | %.2f | %.1f |\n", condition, c.state.c_str(), c.kept,
              c.dropped, c.wall_s, c.kept_per_s());
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 5;
  int frames = 300, runs = 1, io_threads = 0, io_nice = -1;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--seconds" && i + 1 < argc) {
      seconds = std::clamp(std::atof(argv[++i]), 0.5, 60.0);
    } else if (arg == "--frames" && i + 1 < argc) {
      frames = std::clamp(std::atoi(argv[++i]), 30, 3000);
    } else if (arg == "--runs" && i + 1 < argc) {
      runs = std::clamp(std::atoi(argv[++i]), 1, 20);
    } else if (arg == "--io-nice" && i + 1 < argc) {
      io_nice = std::clamp(std::atoi(argv[++i]), 0, 19);
    } else if (arg == "--io-threads" && i + 1 < argc) {
      io_threads = std::clamp(std::atoi(argv[++i]), 1, 64);
    } else {
      std::fprintf(stderr,
                   "usage: status_load_bench [--seconds S] [--frames N] [--runs R] "
                   "[--io-threads T] [--io-nice K]\n");
      return 2;
    }
  }
  const fs::path dir = fresh_test_dir("status_load");
  const std::string examples = fs::path(CAMLAB_SOURCE_DIR) / "mock_device/examples";
  std::vector<std::string> args = {"--no-scan", "--camera-spec", examples + "/camera_640x480.json",
                                   "--scene", examples + "/scene_slanted_edges.json"};
  std::string options;
  if (io_threads > 0) {
    args.insert(args.end(), {"--io-threads", std::to_string(io_threads)});
    options += " --io-threads " + std::to_string(io_threads);
  }
  if (io_nice >= 0) {
    args.insert(args.end(), {"--io-nice", std::to_string(io_nice)});
    options += " --io-nice " + std::to_string(io_nice);
  }
  Daemon daemon;
  if (!daemon.start(dir, args)) {
    std::fprintf(stderr, "camlabd did not start:\n%s\n", daemon.log().c_str());
    return 1;
  }
  const std::string camera = "/v1/cameras/" + url_segment(daemon.camera_id());
  // A one-frame capture: the finished job the load asks for (it also probes the latency).
  auto first = daemon.post(camera + "/captures", {{"kind", "single"}});
  const int64_t finished_id = first.json()["id"];
  daemon.wait_finished(finished_id);
  const std::string path = "/v1/jobs/" + std::to_string(finished_id);

  std::printf(
      "GET %s (a finished job), keep-alive, one epoll client thread, %.1f s per run; "
      "%d-frame single captures on the 640x480 example camera at 30 frames/s%s\n\n",
      path.c_str(), seconds, frames,
      io_threads > 0 ? (", --io-threads " + std::to_string(io_threads)).c_str() : "");
  std::printf(
      "| condition | connections | requests/s | p50 ms | p99 ms | non-200 | of them 503 | "
      "reconnects |\n|---|---|---|---|---|---|---|---|\n");
  std::vector<std::pair<std::string, CaptureResult>> captures;
  for (int run = 0; run < runs; ++run) {
    captures.emplace_back("alone", capture(daemon, camera, frames, nullptr));
    for (int n : {16, 64, 256})
      print_load("idle", load(daemon.port(), daemon.token(), path, n, seconds));
    // The load covers 90% of the capture's frame clock, so its kept frames/s is the rate
    // under load and not diluted by a quiet tail.
    const double busy_s = 0.9 * frames / 30.0;
    for (int n : {16, 64, 256}) {
      LoadResult busy;
      CaptureResult c = capture(daemon, camera, frames, [&] {
        busy = load(daemon.port(), daemon.token(), path, n, busy_s);
      });
      print_load("capture running", busy);
      char condition[96];
      std::snprintf(condition, sizeof condition, "with %d connections for %.1f s", n, busy_s);
      captures.emplace_back(condition, c);
    }
  }
  std::printf(
      "\n| capture | state | kept | dropped | wall s | kept frames/s |\n"
      "|---|---|---|---|---|---|\n");
  for (const auto& [condition, c] : captures) print_capture(condition.c_str(), c);
  daemon.stop(SIGTERM);
  fs::remove_all(dir);
  return 0;
}
