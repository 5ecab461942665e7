// camlabd at sensor rate (docs/BENCHMARKS.md, "camlabd at sensor rate"): long captures
// through the REST API on in-process virtual cameras at 30 frames/s, and what they cost:
//   - a single capture of N frames (one setting, N repeats);
//   - a bracket of N exposures, one frame each (a control change every frame);
// frames kept, frames consumed against the minimum N + control latency, frames dropped
// by the device and by camlabd, steps retaken, wall time against the frame clock, and the
// frame writer's deepest queue. The first capture on each camera (one frame) also probes
// the control latency and is not counted.
//
//   sensor_rate_bench [--frames N] [--runs R]
//
// Cameras: the 640x480 example camera with noise off looking at slanted edges, a 160x120
// camera with shot and read noise, and the 640x480 camera with noise on. On a quiet
// machine all three deliver every frame on time; under load the noisy 640x480 one falls
// behind and is measured at the rate it does deliver (what camlabd does with a camera
// that cannot keep up).
// Prints; never passes or fails.
#include <algorithm>
#include <cstdio>
#include <cstdlib>

#include "daemon_harness.h"

namespace {

using namespace camlab::testing;
using nlohmann::json;

json camera_640(bool noise) {
  json camera = json::parse(
      read_file(fs::path(CAMLAB_SOURCE_DIR) / "mock_device/examples/camera_640x480.json"));
  camera["name"] = noise ? "bench 640x480 noise on" : "bench 640x480 noise off";
  camera["sensor"]["shot_noise"] = noise;
  camera["sensor"]["read_noise_e"] = noise ? 3.0 : 0.0;
  return camera;
}

json camera_160_noisy() {
  json camera = camera_640(true);
  camera["name"] = "bench 160x120 noise on";
  camera["sensor"]["width_px"] = 160;
  camera["sensor"]["height_px"] = 120;
  camera["sensor"]["pixel_pitch_um"] = 16.0;  // the same field of view
  return camera;
}

struct Row {
  std::string camera, capture, state;
  int n = 0, latency = 0, kept = 0, consumed = 0, dropped = 0, dropped_device = 0,
      dropped_camlabd = 0, refused = 0, retaken = 0, queue = 0, commits = 0;
  double wall_s = 0, interval_s = 0;
};

Row run_capture(const Daemon& daemon, const std::string& camera_path, const std::string& name,
                const std::string& what, const json& request, double interval_s) {
  Row row{name, what};
  row.interval_s = interval_s;
  auto posted = daemon.post(camera_path + "/captures", request);
  if (posted.status != 202) {
    row.state = "refused: " + posted.body;
    return row;
  }
  const json job = daemon.wait_finished(posted.json()["id"], std::chrono::seconds(600));
  row.state = job.value("state", "?");
  const json& r = job["result"];
  if (!r.is_object()) return row;
  row.n = r.value("frames_total", 0);
  row.latency = r.value("control_latency_frames", 0);
  row.kept = r.value("frames_kept", 0);
  row.consumed = r.value("frames_consumed", 0);
  row.dropped = r.value("frames_dropped", 0);
  // -1: a camlabd that does not tell them apart.
  row.dropped_device = r.value("frames_dropped_by_device", -1);
  row.dropped_camlabd = r.value("frames_dropped_by_camlabd", -1);
  row.refused = r.value("frames_refused_by_writer", -1);
  row.retaken = r.value("steps_retaken", 0);
  row.wall_s = r.value("wall_seconds", 0.0);
  row.queue = row.commits = -1;
  if (r.contains("writer")) {
    row.queue = r["writer"].value("most_frames_queued", 0);
    row.commits = r["writer"].value("commits", 0);
  }
  return row;
}

std::string count(int n) { return n < 0 ? "-" : std::to_string(n); }

void print(const Row& r) {
  const double clock_s = (r.n + r.latency) * r.interval_s;
  std::printf(
      "| %s | %s | %s | %d | %d | %d | %d | %d | %d | %s | %s (%s writer) | %d | %.2f | %.2f | "
      "%.1f | %s | %s |\n",
      r.camera.c_str(), r.capture.c_str(), r.state.c_str(), r.n, r.latency, r.kept, r.consumed,
      r.n + r.latency + 1, r.dropped, count(r.dropped_device).c_str(),
      count(r.dropped_camlabd).c_str(), count(r.refused).c_str(), r.retaken, r.wall_s, clock_s,
      r.wall_s > 0 ? r.kept / r.wall_s : 0.0, count(r.queue).c_str(), count(r.commits).c_str());
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  int frames = 300, runs = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--frames" && i + 1 < argc) {
      frames = std::clamp(std::atoi(argv[++i]), 1, 1000);
    } else if (arg == "--runs" && i + 1 < argc) {
      runs = std::clamp(std::atoi(argv[++i]), 1, 20);
    } else {
      std::fprintf(stderr, "usage: sensor_rate_bench [--frames N] [--runs R]\n");
      return 2;
    }
  }
  const fs::path dir = fresh_test_dir("sensor_rate");
  const std::string scene =
      (fs::path(CAMLAB_SOURCE_DIR) / "mock_device/examples/scene_slanted_edges.json").string();
  struct Camera {
    std::string name;
    json spec;
  };
  const Camera cameras[] = {
      {"640x480 10-bit, noise off, slanted edges", camera_640(false)},
      {"160x120 10-bit, shot + read noise, slanted edges", camera_160_noisy()},
      {"640x480 10-bit, shot + read noise, slanted edges", camera_640(true)}};
  // 100 us .. N x 100 us: every frame a new exposure, all within the 33.3 ms frame.
  json exposures = json::array();
  for (int k = 1; k <= frames; ++k) exposures.push_back(100 * (1 + (k - 1) % 330));

  std::printf("camlabd: %d-frame captures at 30 frames/s (frame interval 33.3 ms)\n\n", frames);
  std::printf(
      "| camera | capture | state | N | latency | kept | consumed | N + latency + 1 | dropped | "
      "dropped by the device | dropped by camlabd | steps retaken | wall s | (N + latency) x "
      "interval s | kept frames/s | writer's deepest queue | commits |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  int index = 0;
  for (const Camera& camera : cameras) {
    const fs::path home = dir / ("camera" + std::to_string(index++));
    fs::create_directories(home);
    std::ofstream(home / "camera.json") << camera.spec.dump();
    Daemon daemon;
    if (!daemon.start(home, {"--no-scan", "--camera-spec", (home / "camera.json").string(),
                             "--scene", scene})) {
      std::fprintf(stderr, "camlabd did not start:\n%s\n", daemon.log().c_str());
      return 1;
    }
    const std::string path = "/v1/cameras/" + url_segment(daemon.camera_id());
    (void)run_capture(daemon, path, camera.name, "probe", {{"kind", "single"}}, 1 / 30.0);
    for (int run = 0; run < runs; ++run) {
      print(run_capture(daemon, path, camera.name, "single",
                        {{"kind", "single"}, {"repeats", frames}}, 1 / 30.0));
      print(run_capture(daemon, path, camera.name, "bracket, 1 frame per exposure",
                        {{"kind", "bracket"}, {"exposures_us", exposures}}, 1 / 30.0));
    }
    daemon.stop(SIGTERM);
  }
  fs::remove_all(dir);
  return 0;
}
