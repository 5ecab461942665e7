// camlabd benchmarks (docs/measuring.md: figures, never pass/fail):
//   1. a 9-exposure bracket on in-process virtual cameras: frames consumed and wall time
//      against the minimum (9 + control latency frames, at the frame interval);
//   2. status-request throughput and p99 latency (GET /v1/jobs/{id}) on loopback, idle
//      and with a capture running, as a ratio measured in the same run: wrk when
//      installed, else a bounded C++ load client (one connection per request).
//
//   service_bench [--quick]
#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <numeric>
#include <thread>

#include "daemon_harness.h"

namespace {

using namespace camlab::testing;
using nlohmann::json;

// The 640x480 camera of mock_device/examples with a plain grey card (cheap to render,
// so the frame clock and not the renderer sets the pace), and the 160x120 test camera.
const char* kCamera640 = R"json({
  "name": "bench 640x480", "sensor": {"width_px": 640, "height_px": 480, "pixel_pitch_um": 4.0, "bit_depth": 10,
  "black_level_dn": 32, "full_well_e": 12000, "read_noise_e": 3.0, "shot_noise": true, "quantum_efficiency": 0.65},
  "lens": {"focal_mm": 8.0, "f_number_min": 1.4, "f_number_max": 16.0},
  "timing": {"frame_interval_us": 33333, "control_latency_frames": 3},
  "controls": {"exposure_time_absolute": {"min": 1, "max": 333, "default": 50}}})json";
const char* kGreyCard =
    R"json({"illuminance_lux": 300, "targets": [{"type": "uniform", "size_m": [2, 2],
  "light_reflectance": 0.5, "pose": {"position_m": [0, 0, 1.5]}}]})json";

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

struct BracketRow {
  std::string camera;
  double frame_interval_ms = 0;
  int latency = 0, kept = 0, consumed = 0, minimum = 0, dropped = 0, retaken = 0;
  double wall_s = 0;
};

BracketRow bench_bracket(const fs::path& dir, const std::string& name,
                         const std::string& camera_json, const std::string& scene_json,
                         double frame_interval_ms, int runs) {
  fs::create_directories(dir);
  std::ofstream(dir / "camera.json") << camera_json;
  std::ofstream(dir / "scene.json") << scene_json;
  Daemon daemon;
  BracketRow row{name, frame_interval_ms};
  if (!daemon.start(dir, {"--no-scan", "--camera-spec", (dir / "camera.json").string(), "--scene",
                          (dir / "scene.json").string()})) {
    std::fprintf(stderr, "camlabd did not start:\n%s\n", daemon.log().c_str());
    return row;
  }
  const std::string camera = "/v1/cameras/" + url_segment(daemon.camera_id());
  // The first capture also probes the control latency; time the later ones.
  const json bracket = {{"kind", "bracket"},
                        {"exposures_us", {500, 700, 1000, 1400, 2000, 2800, 4000, 5600, 8000}}};
  std::vector<double> walls, consumed, dropped, retaken;
  for (int run = 0; run <= runs; ++run) {
    auto r = daemon.post(camera + "/captures", bracket);
    if (r.status != 202) {
      std::fprintf(stderr, "capture refused: %s\n", r.body.c_str());
      break;
    }
    const json job = daemon.wait_finished(r.json()["id"]);
    if (job["state"] != "succeeded") {
      std::fprintf(stderr, "capture %s: %s\n", job.value("state", "?").c_str(), job.dump().c_str());
      break;
    }
    const json& result = job["result"];
    row.latency = result["control_latency_frames"];
    row.kept = result["frames_kept"];
    row.minimum = result["frames_minimum"];
    if (run == 0) continue;
    walls.push_back(result["wall_seconds"].get<double>());
    consumed.push_back(result["frames_consumed"].get<double>());
    dropped.push_back(result["frames_dropped"].get<double>());
    retaken.push_back(result["steps_retaken"].get<double>());
  }
  row.wall_s = median(walls);
  row.consumed = static_cast<int>(median(consumed));
  row.dropped = static_cast<int>(median(dropped));
  row.retaken = static_cast<int>(median(retaken));
  daemon.stop(SIGTERM);
  return row;
}

struct LoadResult {
  double requests_per_s = 0, p50_ms = 0, p99_ms = 0;
  std::string tool;
};

double wrk_latency_ms(const std::string& text, const std::string& label) {
  // "     99%    1.23ms" (or us / s)
  const size_t at = text.find(" " + label + " ");
  if (at == std::string::npos) return -1;
  double value = 0;
  char unit[8] = {0};
  if (std::sscanf(text.c_str() + at + label.size() + 2, "%lf%7s", &value, unit) != 2) return -1;
  const std::string u = unit;
  return u == "us" ? value / 1000 : u == "s" ? value * 1000 : value;
}

LoadResult load(const Daemon& daemon, const std::string& path, int seconds) {
  LoadResult result;
  if (std::system("command -v wrk >/dev/null 2>&1") == 0) {
    result.tool = "wrk -t2 -c16";
    const std::string command =
        "wrk -t2 -c16 -d" + std::to_string(seconds) + "s --latency -H 'Authorization: Bearer " +
        daemon.token() + "' http://127.0.0.1:" + std::to_string(daemon.port()) + path + " 2>&1";
    std::string text;
    if (FILE* pipe = popen(command.c_str(), "r")) {
      char buffer[4096];
      for (size_t n; (n = fread(buffer, 1, sizeof buffer, pipe)) > 0;) text.append(buffer, n);
      pclose(pipe);
    }
    if (auto at = text.find("Requests/sec:"); at != std::string::npos)
      result.requests_per_s = std::atof(text.c_str() + at + 13);
    result.p50_ms = wrk_latency_ms(text, "50%");
    result.p99_ms = wrk_latency_ms(text, "99%");
    if (text.find("Non-2xx") != std::string::npos)
      std::fprintf(stderr, "wrk saw errors:\n%s\n", text.c_str());
    return result;
  }
  // Fallback: 8 client threads, one connection per request, bounded by time.
  result.tool = "C++ client, 8 threads, connection per request";
  std::vector<std::vector<double>> latencies(8);
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(seconds);
  std::vector<std::thread> threads;
  for (auto& mine : latencies)
    threads.emplace_back([&, &mine = mine] {
      while (std::chrono::steady_clock::now() < end) {
        const auto t0 = std::chrono::steady_clock::now();
        auto r = http(daemon.port(), "GET", path, daemon.token());
        if (r.status != 200) continue;
        mine.push_back(
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                .count());
      }
    });
  for (auto& t : threads) t.join();
  std::vector<double> all;
  for (auto& l : latencies) all.insert(all.end(), l.begin(), l.end());
  std::sort(all.begin(), all.end());
  if (!all.empty()) {
    result.requests_per_s = all.size() / static_cast<double>(seconds);
    result.p50_ms = all[all.size() / 2];
    result.p99_ms = all[std::min(all.size() - 1, all.size() * 99 / 100)];
  }
  return result;
}

}  // namespace

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::string(argv[1]) == "--quick";
  const fs::path dir = fresh_test_dir("bench");
  const int runs = quick ? 2 : 5;

  std::printf(
      "## 9-exposure bracket (0.5..8 ms): frames consumed and wall time against the minimum\n");
  std::printf("median of %d runs after a first run that also probes the latency\n\n", runs);
  std::printf(
      "| camera | frame interval ms | latency frames | frames kept | frames consumed | minimum (9 "
      "+ latency) "
      "| dropped by the device | steps retaken | wall s | minimum wall s | wall / minimum |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|\n");
  std::vector<BracketRow> rows = {
      bench_bracket(dir / "b160", "160x120 test camera, slanted edge", kTestCameraSpec,
                    kTestSceneSpec, 20.0, runs),
      bench_bracket(dir / "b640", "640x480, grey card, shot + read noise", kCamera640, kGreyCard,
                    33.333, runs)};
  for (const auto& r : rows) {
    const double minimum_wall = r.minimum * r.frame_interval_ms / 1000;
    std::printf("| %s | %.1f | %d | %d | %d | %d | %d | %d | %.3f | %.3f | %.2f |\n",
                r.camera.c_str(), r.frame_interval_ms, r.latency, r.kept, r.consumed, r.minimum,
                r.dropped, r.retaken, r.wall_s, minimum_wall,
                minimum_wall > 0 ? r.wall_s / minimum_wall : 0.0);
  }

  std::printf(
      "\n## Status requests (GET /v1/jobs/{id}) on loopback, idle and during a capture\n\n");
  write_test_specs(dir);
  Daemon daemon;
  if (!daemon.start(dir / "load", {"--no-scan", "--camera-spec", (dir / "camera.json").string(),
                                   "--scene", (dir / "scene.json").string()})) {
    std::fprintf(stderr, "camlabd did not start:\n%s\n", daemon.log().c_str());
    return 1;
  }
  const std::string camera = "/v1/cameras/" + url_segment(daemon.camera_id());
  auto first = daemon.post(camera + "/captures", {{"kind", "single"}});
  const int64_t first_id = first.json()["id"];
  daemon.wait_finished(first_id);
  const int seconds = quick ? 3 : 8;
  const LoadResult idle = load(daemon, "/v1/jobs/" + std::to_string(first_id), seconds);
  // A capture long enough to outlast the load: 9 exposures x 100 repeats at 50 frames/s.
  auto busy_job =
      daemon.post(camera + "/captures",
                  {{"kind", "bracket"},
                   {"repeats", 100},
                   {"exposures_us", {500, 700, 1000, 1400, 2000, 2800, 4000, 5600, 8000}}});
  const int64_t busy_id = busy_job.json()["id"];
  daemon.wait_job(busy_id, [](const json& j) { return j["state"] == "running"; });
  const LoadResult busy = load(daemon, "/v1/jobs/" + std::to_string(busy_id), seconds);
  const json during = daemon.get("/v1/jobs/" + std::to_string(busy_id)).json();
  std::printf("tool: %s, %d s per run\n\n", idle.tool.c_str(), seconds);
  std::printf("| condition | requests/s | p50 ms | p99 ms |\n|---|---|---|---|\n");
  std::printf("| idle | %.0f | %.3f | %.3f |\n", idle.requests_per_s, idle.p50_ms, idle.p99_ms);
  std::printf("| capture running (%d frames written meanwhile) | %.0f | %.3f | %.3f |\n",
              during["progress"]["frames_done"].get<int>(), busy.requests_per_s, busy.p50_ms,
              busy.p99_ms);
  std::printf("\nthroughput during capture / idle = %.2f; p99 during / idle = %.2f\n",
              idle.requests_per_s > 0 ? busy.requests_per_s / idle.requests_per_s : 0.0,
              idle.p99_ms > 0 ? busy.p99_ms / idle.p99_ms : 0.0);
  daemon.del("/v1/jobs/" + std::to_string(busy_id));
  daemon.wait_finished(busy_id);
  daemon.stop(SIGTERM);
  fs::remove_all(dir);
  return 0;
}
