// camlabd under two kinds of pressure from the second outside review (docs/BENCHMARKS.md,
// "camlabd under pressure"). A benchmark: it prints, never fails.
//
// 1. Long-polls on a fleet host: PostgreSQL transactions per second (pg_stat_database's
//    xact_commit) with the host idle and with N requests GET /v1/jobs/{id}?wait=60 on a
//    running capture, each from its own connection and re-sent as soon as it is answered
//    (a client at the waiter cap is answered at once and asks again). The review measured
//    1,258-1,455/s for 250 waiters against 44/s idle.
// 2. Slow readers: N connections that pipeline requests for /ui/app.js and read nothing,
//    then GET /v1/health from a new connection every 100 ms for the given seconds: how many
//    were answered 200, and the slowest answer. The review saw 503 for 35-41 s per round.
//
// Usage: service_pressure_bench [--waiters N] [--readers N] [--seconds S]
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include "tests/integration/service/fleet_harness.h"

namespace {

using namespace camlab::testing;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

int64_t commits(PgCluster& cluster) {
  return std::atoll(
      cluster.sql("postgres", "SELECT xact_commit FROM pg_stat_database WHERE datname = 'camlab'")
          .c_str());
}

double commits_per_s(PgCluster& cluster, int seconds) {
  const int64_t before = commits(cluster);
  const auto t0 = Clock::now();
  std::this_thread::sleep_for(std::chrono::seconds(seconds));
  const int64_t after = commits(cluster);
  return (after - before) / std::chrono::duration<double>(Clock::now() - t0).count();
}

void long_polls(int waiters, int seconds) {
  const fs::path dir = fresh_test_dir("service_pressure_bench_polls");
  FleetHarness fleet(dir, kTestCameraSpec);
  std::string error;
  if (!fleet.start_database(&error)) {
    std::printf("long-polls: no PostgreSQL (%s)\n", error.c_str());
    return;
  }
  Daemon* host = fleet.start_host("host-1", 10000);
  if (!host || fleet.wait_live(*host, 1).is_null()) {
    std::printf("long-polls: the host did not start\n%s\n", fleet.logs().c_str());
    return;
  }
  const std::string camera = "/v1/cameras/" + url_segment(host->camera_id());
  auto capture = host->post(camera + "/captures", {{"kind", "single"}, {"repeats", 5000}});
  const int64_t id = capture.json().value("id", int64_t{0});
  std::this_thread::sleep_for(std::chrono::seconds(1));
  const double idle = commits_per_s(fleet.cluster(), seconds);
  std::atomic<bool> stop{false};
  std::atomic<int64_t> answers{0};
  std::vector<std::thread> clients;
  for (int i = 0; i < waiters; ++i)
    clients.emplace_back([&] {
      while (!stop) {
        auto r = http(host->port(), "GET", "/v1/jobs/" + std::to_string(id) + "?wait=60",
                      host->token(), "", std::chrono::milliseconds(65000));
        ++answers;
        if (r.status != 200) std::this_thread::sleep_for(std::chrono::milliseconds(100));
      }
    });
  std::this_thread::sleep_for(std::chrono::seconds(1));
  const int64_t answers_before = answers;
  const double polling = commits_per_s(fleet.cluster(), seconds);
  const double answers_per_s = (answers - answers_before) / static_cast<double>(seconds);
  std::printf(
      "long-polls  %4d waiters  idle %8.1f transactions/s  with them %8.1f/s  ratio %5.2f  "
      "(%.0f answers/s: the clients past the waiter cap, answered at once, asking again)\n",
      waiters, idle, polling, idle > 0 ? polling / idle : 0.0, answers_per_s);
  stop = true;
  host->del("/v1/jobs/" + std::to_string(id));
  for (auto& t : clients) t.join();
}

void slow_readers(int readers, int seconds) {
  const fs::path dir = fresh_test_dir("service_pressure_bench_readers");
  write_test_specs(dir);
  Daemon daemon;
  if (!daemon.start(dir, {"--no-scan", "--camera-spec", (dir / "camera.json").string(), "--scene",
                          (dir / "scene.json").string()})) {
    std::printf("slow readers: camlabd did not start\n%s\n", daemon.log().c_str());
    return;
  }
  std::string pipelined;
  for (int i = 0; i < 2000; ++i) pipelined += "GET /ui/app.js HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n";
  std::vector<int> fds;
  for (int i = 0; i < readers; ++i) {
    const int fd = connect_loopback(daemon.port(), 4096);
    if (fd < 0) continue;
    (void)::send(fd, pipelined.data(), pipelined.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    fds.push_back(fd);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  int asked = 0, ok = 0;
  double slowest_ms = 0;
  const auto end = Clock::now() + std::chrono::seconds(seconds);
  while (Clock::now() < end) {
    const auto t0 = Clock::now();
    auto r = http(daemon.port(), "GET", "/v1/health", "", "", std::chrono::milliseconds(10000));
    slowest_ms =
        std::max(slowest_ms, std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    ++asked;
    ok += r.status == 200 ? 1 : 0;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  std::printf(
      "slow readers %4d  /v1/health from new connections: %d of %d answered 200, slowest "
      "%.1f ms (max-connections 256)\n",
      readers, ok, asked, slowest_ms);
  for (int fd : fds) ::close(fd);
  daemon.stop(SIGTERM);
  fs::remove_all(dir);
}

}  // namespace

int main(int argc, char** argv) {
  int waiters = 250, readers = 256, seconds = 5;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--waiters") waiters = std::atoi(argv[i + 1]);
    if (flag == "--readers") readers = std::atoi(argv[i + 1]);
    if (flag == "--seconds") seconds = std::max(1, std::atoi(argv[i + 1]));
  }
  slow_readers(readers, seconds);
  long_polls(waiters, seconds);
  return 0;
}
