// camlabd hot-plug and libcamera figures (docs/measuring.md: figures, never pass/fail):
//   1. unplug during a 100-frame capture -> the job ends device_lost, and replug -> the
//      same camera id available again, in ms: an in-process virtual camera (test fault
//      API, which announces the replug as a hot-plug event), and the virtual camera under
//      `camlab vcam run` as a V4L2 node and through libcamera (broker faults; only the
//      1 s rescan notices, as /dev there makes no inotify events);
//   2. a 1/2/4/8 ms bracket through libcamera (--prefer-libcamera): the worst deviation of
//      the mean signal above black per unit exposure from the 1 ms frame's.
//
//   hotplug_bench [--quick]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>

#include "capture_checks.h"
#include "vcam_launch.h"

namespace {

using namespace camlab::testing;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

const char* kCamera = R"json({
  "name": "bench camera", "sensor": {"width_px": 160, "height_px": 120, "pixel_pitch_um": 4.0,
  "bit_depth": 10, "black_level_dn": 32, "full_well_e": 12000, "read_noise_e": 30, "shot_noise": false,
  "quantum_efficiency": 0.65},
  "lens": {"focal_mm": 8.0, "f_number_min": 1.4, "f_number_max": 16.0,
           "iris": {"f_numbers": [16, 11, 8, 5.6, 4, 2.8, 2, 1.4]}},
  "timing": {"frame_interval_us": 20000, "control_latency_frames": 3},
  "controls": {"exposure_time_absolute": {"min": 1, "max": 200, "default": 10},
               "iris_absolute": {"default": 5}}})json";

double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

struct Stats {
  std::vector<double> values;
  void add(double v) { values.push_back(v); }
  void print(const char* what, const char* unit) const {
    if (values.empty()) return (void)std::printf("%-52s no runs\n", what);
    std::vector<double> v = values;
    std::sort(v.begin(), v.end());
    std::printf("%-52s median %7.1f %s  max %7.1f %s  (%zu runs)\n", what, v[v.size() / 2], unit,
                v.back(), unit, v.size());
  }
};

bool camera_available(const Daemon& daemon, const std::string& id) {
  const json list = daemon.get("/v1/cameras").json();
  if (!list.is_object()) return false;
  for (const auto& c : list["cameras"])
    if (c.value("id", "") == id) return c.value("present", false) && c.value("available", false);
  return false;
}

// One unplug/replug cycle; false when something did not happen within its bound.
template <class Unplug, class Replug>
bool cycle(const Daemon& daemon, Unplug unplug, Replug replug, Stats* lost, Stats* back) {
  const std::string id = daemon.camera_id();
  const std::string camera = "/v1/cameras/" + url_segment(id);
  auto r = daemon.post(camera + "/captures", {{"kind", "single"}, {"repeats", 100}});
  if (r.status != 202) return false;
  const int64_t job = r.json()["id"];
  daemon.wait_job(
      job, [](const json& j) { return j["progress"]["frames_done"] >= 5; }, 30s);
  auto t = Clock::now();
  unplug();
  json done;  // polled every 5 ms (the harness's wait polls every 50)
  for (auto end = Clock::now() + 30s; Clock::now() < end; std::this_thread::sleep_for(5ms)) {
    done = daemon.get("/v1/jobs/" + std::to_string(job)).json();
    if (done.is_object() && done.value("state", "") != "running") break;
  }
  if (!done.is_object() || done.value("state", "") != "device_lost") return false;
  lost->add(ms_since(t));
  // Wait until the rescan has retired it, so that the replug is seen as one.
  for (auto end = Clock::now() + 10s; Clock::now() < end && camera_available(daemon, id);)
    std::this_thread::sleep_for(10ms);
  t = Clock::now();
  replug();
  for (auto end = Clock::now() + 15s; Clock::now() < end;) {
    if (camera_available(daemon, id)) {
      back->add(ms_since(t));
      return true;
    }
    std::this_thread::sleep_for(5ms);
  }
  return false;
}

void bench_in_process(const fs::path& dir, int runs) {
  Daemon daemon;
  if (!daemon.start(dir, {"--no-scan", "--camera-spec", (dir / "camera.json").string(), "--scene",
                          (dir / "scene.json").string(), "--test-faults"})) {
    std::fprintf(stderr, "camlabd did not start:\n%s\n", daemon.log().c_str());
    return;
  }
  const std::string faults = "/v1/test/cameras/" + url_segment(daemon.camera_id()) + "/faults";
  Stats lost, back;
  for (int i = 0; i < runs; ++i)
    if (!cycle(
            daemon,
            [&] {
              daemon.post(faults, {{"unplug", true}});
            },
            [&] {
              daemon.post(faults, {{"replug", true}});
            },
            &lost, &back))
      std::fprintf(stderr, "in-process cycle %d failed\n", i);
  lost.print("in-process: unplug -> job device_lost", "ms");
  back.print("in-process: replug -> available (fault API event)", "ms");
}

void bench_vcam(const fs::path& dir, bool libcamera, int runs) {
  Daemon daemon;
  std::vector<std::string> args = {"--no-virtual", "--device-spec", (dir / "camera.json").string()};
  args.push_back(libcamera ? "--prefer-libcamera" : "--no-libcamera");
  if (!daemon.start(dir, args,
                    vcam_prefix_saving_broker(dir, (dir / "camera.json").string(),
                                              (dir / "scene.json").string()))) {
    std::fprintf(stderr, "camlabd did not start:\n%s\n", daemon.log().c_str());
    return;
  }
  const char* name = libcamera ? "vcam run, libcamera" : "vcam run, V4L2";
  Stats lost, back;
  for (int i = 0; i < runs; ++i)
    if (!cycle(
            daemon, [&] { run_cli_with_broker(dir, "vcam fault unplug"); },
            [&] { run_cli_with_broker(dir, "vcam fault replug"); }, &lost, &back))
      std::fprintf(stderr, "%s cycle %d failed\n", name, i);
  lost.print((std::string(name) + ": unplug -> job device_lost").c_str(), "ms");
  back.print((std::string(name) + ": replug -> available (1 s rescan)").c_str(), "ms");
  if (!libcamera) return;
  Stats error;
  const std::string camera = "/v1/cameras/" + url_segment(daemon.camera_id());
  for (int i = 0; i < runs; ++i)
    error.add(100 * check_bracket_is_linear(daemon, camera, json::object(), -1));
  error.print("libcamera 1/2/4/8 ms bracket: worst signal/exposure error", "%");
}

}  // namespace

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::strcmp(argv[1], "--quick") == 0;
  const int runs = quick ? 2 : 10;
  const fs::path dir = fresh_test_dir("hotplug_bench");
  for (const char* sub : {"in_process", "vcam", "libcamera"}) {
    fs::create_directories(dir / sub);
    std::ofstream(dir / sub / "camera.json") << kCamera;
    std::ofstream(dir / sub / "scene.json") << kTestSceneSpec;
  }
  bench_in_process(dir / "in_process", runs);
  bench_vcam(dir / "vcam", false, runs);
  bench_vcam(dir / "libcamera", true, runs);
  fs::remove_all(dir);
  return 0;
}
