// Frames consumed and wall time of a 9-exposure bracket against the minimum (9 frames +
// the control latency), on the virtual camera in real time (its V4L2 device in process,
// through camlab's V4L2 backend), for control latencies 0, 1 and 3; and the bracket's
// linearity (signal above black per microsecond, every kept frame against their mean).
//
//   capture_plan_bench [--runs N] [--interval-us U]
//
// Two strategies per latency: "early" writes the next step's controls as soon as the
// frames the current step still needs are secured (an exact latency: the default), and
// "after last" waits until the last needed frame has started (a latency known only as an
// upper bound: control_latency_min_frames = 0). Medians over the runs.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "capture/capture_runner.h"
#include "device/v4l2/v4l2_camera.h"
#include "image/capture_folder.h"
#include "mock_device/v4l2/virtual_v4l2_io.h"

namespace {

using nlohmann::json;

struct Run {
  int consumed = 0;
  int minimum = 0;
  double wall_s = 0;
  double linearity_error = 0;  // max |signal per us / mean - 1|
  bool ok = false;
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

Run run_once(int latency, bool exact, double interval_us, int index) {
  Run run;
  auto camera_json = camlab::mock::load_camera_spec(std::string(CAMLAB_SOURCE_DIR) +
                                                    "/mock_device/examples/camera_640x480.json");
  if (!camera_json) return run;
  json spec = camera_json->source;
  spec["sensor"]["width_px"] = 160;  // small frames: the loop, not the renderer, is measured
  spec["sensor"]["height_px"] = 120;
  spec["timing"] = {{"frame_interval_us", interval_us}, {"control_latency_frames", latency}};
  spec["controls"]["exposure_time_absolute"]["max"] = static_cast<int>(interval_us / 100);
  auto camera_spec = camlab::mock::parse_camera_spec(spec);
  auto scene = camlab::mock::parse_scene_spec({{"illuminance_lux", 1000},
                                               {"targets",
                                                {{{"type", "uniform"},
                                                  {"size_m", {10.0, 10.0}},
                                                  {"light_reflectance", 0.5},
                                                  {"pose", {{"position_m", {0.0, 0.0, 1.0}}}}}}}});
  if (!camera_spec || !scene) {
    std::fprintf(stderr, "spec: %s\n",
                 (!camera_spec ? camera_spec.error() : scene.error()).message.c_str());
    return run;
  }
  const camlab::mock::CameraSpec truth = *camera_spec;
  auto device =
      camlab::mock::VirtualV4l2Device::create(std::move(*camera_spec), std::move(*scene), {});
  if (!device) return run;
  std::shared_ptr<camlab::mock::VirtualV4l2Device> shared = std::move(*device);
  auto io = std::make_shared<camlab::mock::VirtualV4l2Io>(std::vector{shared});
  auto camera = camlab::device::V4l2Camera::open(io, "/dev/video0");
  if (!camera) return run;

  camlab::capture::CameraTraits traits;
  traits.sensor_bit_depth = truth.sensor.bit_depth;
  traits.black_level_dn = truth.sensor.black_level_dn;
  traits.gain_unity = truth.controls.gain_unity;
  traits.f_number_by_iris_position = truth.lens.iris.f_numbers;
  json request = {{"kind", "bracket"},
                  {"base_exposure_us", 2000},
                  {"ev_steps", {-2, -1.5, -1, -0.5, 0, 0.5, 1, 1.5, 2}}};
  auto plan =
      camlab::capture::plan_capture(request, *(*camera)->controls(), *(*camera)->formats(), traits);
  if (!plan) {
    std::fprintf(stderr, "plan: %s\n", plan.error().message.c_str());
    return run;
  }
  const auto folder =
      std::filesystem::temp_directory_path() /
      ("camlab_plan_bench_" + std::to_string(::getpid()) + "_" + std::to_string(index));
  std::filesystem::remove_all(folder);
  camlab::capture::CaptureOptions options;
  options.control_latency_frames = latency;
  options.control_latency_min_frames = exact ? -1 : 0;
  auto summary = camlab::capture::run_capture(**camera, *plan, folder, options, nullptr);
  if (!summary || summary->failure) {
    std::fprintf(stderr, "capture: %s\n",
                 (!summary ? summary.error() : *summary->failure).message.c_str());
    std::filesystem::remove_all(folder);
    return run;
  }
  run.consumed = summary->frames_consumed;
  run.minimum = summary->frames_minimum;
  run.wall_s = summary->wall_seconds;
  auto captured = camlab::image::CaptureFolder::open(folder);
  std::vector<double> per_us;
  for (int i = 0; captured && i < static_cast<int>(captured->frames().size()); ++i) {
    auto image = captured->load_image(i);
    auto sidecar = captured->load_sidecar(i);
    if (!image || !sidecar) break;
    per_us.push_back((cv::mean(*image)[0] - sidecar->black_level_dn) /
                     sidecar->settings["exposure_us"].get<double>());
  }
  double mean = 0;
  for (double r : per_us) mean += r / static_cast<double>(per_us.size());
  for (double r : per_us)
    run.linearity_error = std::max(run.linearity_error, std::abs(r / mean - 1));
  run.ok = per_us.size() == 9;
  std::filesystem::remove_all(folder);
  return run;
}

}  // namespace

int main(int argc, char** argv) {
  int runs = 5;
  double interval_us = 33333;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--runs") && i + 1 < argc)
      runs = std::max(1, std::atoi(argv[++i]));
    else if (!std::strcmp(argv[i], "--interval-us") && i + 1 < argc)
      interval_us = std::atof(argv[++i]);
    else {
      std::fprintf(stderr, "usage: %s [--runs N] [--interval-us U]\n", argv[0]);
      return 2;
    }
  }
  std::printf(
      "9-exposure bracket (EV -2..+2 around 2 ms), virtual camera 160x120 Y16 in real time, "
      "frame interval %.1f ms, median of %d runs\n\n",
      interval_us / 1000, runs);
  std::printf(
      "| latency | strategy | frames consumed | minimum (9 + latency) | wall s | wall / minimum x "
      "interval | "
      "max linearity error %% |\n|---|---|---|---|---|---|---|\n");
  int index = 0;
  for (int latency : {0, 1, 3}) {
    for (bool exact : {true, false}) {
      std::vector<double> consumed, wall, error;
      int minimum = 0, failed = 0;
      for (int r = 0; r < runs; ++r) {
        Run run = run_once(latency, exact, interval_us, index++);
        if (!run.ok) {
          ++failed;
          continue;
        }
        consumed.push_back(run.consumed);
        wall.push_back(run.wall_s);
        error.push_back(run.linearity_error);
        minimum = run.minimum;
      }
      if (consumed.empty()) {
        std::printf("| %d | %s | failed | | | | |\n", latency, exact ? "early" : "after last");
        continue;
      }
      const double ideal_s = minimum * interval_us * 1e-6;
      std::printf("| %d | %s | %.0f | %d | %.3f | %.2f | %.2f |%s\n", latency,
                  exact ? "early" : "after last", median(consumed), minimum, median(wall),
                  median(wall) / ideal_s, 100 * *std::max_element(error.begin(), error.end()),
                  failed ? (" (" + std::to_string(failed) + " runs failed)").c_str() : "");
    }
  }
  return 0;
}
