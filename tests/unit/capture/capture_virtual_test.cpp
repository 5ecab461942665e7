// Captures on the virtual camera (its V4L2 device in process, through camlab's V4L2
// backend) checked against the physics it renders: a bracket's signal is proportional to
// exposure with a control latency of 3 frames, a focus stack is sharpest where the truth
// focuses on the target, an aperture series falls as 1/N^2; and faults mid-run.
#include <gtest/gtest.h>
#include <linux/videodev2.h>

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "capture/capture_runner.h"
#include "image/capture_folder.h"
#include "virtual_camera.h"

namespace camlab::capture {
namespace {

using nlohmann::json;

struct Captured {
  CaptureSummary summary;
  std::vector<cv::Mat> images;
  std::vector<image::FrameSidecar> sidecars;
  bool complete = false;
};

Captured capture(testing::VirtualCamera& vcam, const json& request, int latency_frames,
                 CaptureObserver* observer = nullptr) {
  Captured out;
  auto controls = vcam.camera->controls();
  auto formats = vcam.camera->formats();
  EXPECT_TRUE(controls.ok() && formats.ok());
  auto plan = plan_capture(request, *controls, *formats, vcam.traits);
  EXPECT_TRUE(plan.ok()) << plan.error().message;
  if (!plan) return out;
  testing::ScratchDir dir("virtual");
  CaptureOptions options;
  options.control_latency_frames = latency_frames;
  options.source = {{"backend", "virtual"}, {"name", vcam.camera->identity().name}};
  auto summary = run_capture(*vcam.camera, *plan, dir / "capture", options, observer);
  EXPECT_TRUE(summary.ok()) << summary.error().message;
  if (!summary) return out;
  out.summary = *summary;
  auto folder = image::CaptureFolder::open(dir / "capture");
  EXPECT_TRUE(folder.ok()) << folder.error().message;
  if (!folder) return out;
  out.complete = folder->complete();
  EXPECT_EQ(folder->manifest()["kind"], plan->kind);
  for (int i = 0; i < static_cast<int>(folder->frames().size()); ++i) {
    auto image = folder->load_image(i);
    auto sidecar = folder->load_sidecar(i);
    EXPECT_TRUE(image.ok() && sidecar.ok())
        << "frame " << i << " of a run cut short must stay readable";
    if (!image || !sidecar) continue;
    out.images.push_back(*image);
    out.sidecars.push_back(*sidecar);
  }
  return out;
}

double signal_above_black(const cv::Mat& image, const image::FrameSidecar& sidecar) {
  return cv::mean(image)[0] - sidecar.black_level_dn;
}

// Every frame's signal per microsecond of exposure, against their mean: within `tolerance`.
void expect_signal_proportional_to_exposure(const Captured& c, double tolerance) {
  std::vector<double> per_us;
  for (size_t i = 0; i < c.images.size(); ++i)
    per_us.push_back(signal_above_black(c.images[i], c.sidecars[i]) /
                     c.sidecars[i].settings["exposure_us"].get<double>());
  double mean = 0;
  for (double r : per_us) mean += r / static_cast<double>(per_us.size());
  for (size_t i = 0; i < per_us.size(); ++i)
    EXPECT_NEAR(per_us[i] / mean, 1.0, tolerance)
        << "frame " << c.sidecars[i].sequence << " at " << c.sidecars[i].settings["exposure_us"]
        << " us does not carry that exposure";
}

// 5000 lux on 50% grey: about 310 DN per ms above black at f/4 and unity gain (12 bits).
json grey_scene() {
  json scene = mock::testing::uniform_scene_json(1.0, 0.5);
  scene["illuminance_lux"] = 5000;
  return scene;
}

TEST(VirtualCapture, BracketSignalIsProportionalToExposureWithLatencyThree) {
  auto vcam = testing::open_virtual_camera(testing::capture_camera_json(3), grey_scene(),
                                           /*realtime=*/true);
  // A state to come back to: aperture-priority auto exposure and some gain.
  ASSERT_TRUE(vcam.camera->set_control("gain", 250).ok());
  ASSERT_TRUE(vcam.camera->set_control("auto_exposure", V4L2_EXPOSURE_APERTURE_PRIORITY).ok());
  Captured c = capture(vcam,
                       {{"kind", "bracket"},
                        {"exposures_us", {1000, 2000, 4000, 8000}},
                        {"gain", 100},
                        {"repeats", 2}},
                       3);
  ASSERT_FALSE(c.summary.failure.has_value()) << c.summary.failure->message;
  EXPECT_TRUE(c.complete);
  ASSERT_EQ(c.images.size(), 8u);
  for (size_t i = 0; i < c.sidecars.size(); ++i) {
    EXPECT_EQ(c.sidecars[i].settings["exposure_us"],
              c.sidecars[i].settings["requested"]["exposure_us"]);
    EXPECT_EQ(c.sidecars[i].settings["gain"], 1.0);
    EXPECT_EQ(c.sidecars[i].bit_depth, 12);
    EXPECT_EQ(c.sidecars[i].black_level_dn, 64);
    EXPECT_EQ(c.sidecars[i].labels["repeat"], static_cast<int>(i % 2));
  }
  const double top = signal_above_black(c.images.back(), c.sidecars.back());
  EXPECT_LT(top + 64, 0.9 * 4095)
      << "8 ms must stay below saturation for the check to mean anything";
  EXPECT_GT(signal_above_black(c.images.front(), c.sidecars.front()), 100);
  expect_signal_proportional_to_exposure(c, 0.02);
  EXPECT_GE(c.summary.frames_consumed, 8 + 3);
  EXPECT_GE(c.sidecars.front().frames_discarded, 3) << "the first frames carry the old exposure";
  // Restored, auto mode last.
  EXPECT_EQ(*vcam.camera->get_control("gain"), 250);
  EXPECT_EQ(*vcam.camera->get_control("auto_exposure"), V4L2_EXPOSURE_APERTURE_PRIORITY);
  EXPECT_EQ(*vcam.camera->get_control("exposure_time_absolute"), 10);
  EXPECT_FALSE(c.summary.restore_error.has_value());
}

double laplacian_variance(const cv::Mat& image) {
  cv::Mat f, lap;
  image.convertTo(f, CV_32F);
  cv::Laplacian(f, lap, CV_32F);
  cv::Scalar mean, stddev;
  cv::meanStdDev(lap, mean, stddev);
  return stddev[0] * stddev[0];
}

TEST(VirtualCapture, FocusStackIsSharpestWhereTheTruthFocusesOnTheTarget) {
  // Position 64 focuses at s = f (f + 64 e) / (64 e) = 8 x 8.064 / 0.064 mm = 1.008 m.
  const double target_m = 8.0 * 8.064 / 0.064 / 1000.0;
  json scene = {{"illuminance_lux", 1000},
                {"background_reflectance", 0.18},
                {"targets",
                 {{{"type", "texture"},
                   {"size_m", {2.0, 2.0}},
                   {"feature_m", 0.002},
                   {"seed", 3},
                   {"dark_reflectance", 0.1},
                   {"light_reflectance", 0.8},
                   {"pose", {{"position_m", {0.0, 0.0, target_m}}}}}}}};
  auto vcam = testing::open_virtual_camera(testing::capture_camera_json(1, 96, 72), scene,
                                           /*realtime=*/false);
  Captured c = capture(vcam,
                       {{"kind", "focus_stack"},
                        {"positions", {0, 32, 64, 96, 128}},
                        {"exposure_us", 2000},
                        {"controls", {{"iris_absolute", 6}}}},  // f/2: a shallow depth of field
                       1);
  ASSERT_FALSE(c.summary.failure.has_value()) << c.summary.failure->message;
  ASSERT_EQ(c.images.size(), 5u);
  size_t sharpest = 0;
  std::vector<double> sharpness;
  for (size_t i = 0; i < c.images.size(); ++i) {
    sharpness.push_back(laplacian_variance(c.images[i]));
    if (sharpness[i] > sharpness[sharpest]) sharpest = i;
    EXPECT_EQ(c.sidecars[i].settings["f_number"], 2.0);
  }
  EXPECT_EQ(c.sidecars[sharpest].settings["focus_position"], 64)
      << "sharpness: " << sharpness[0] << " " << sharpness[1] << " " << sharpness[2] << " "
      << sharpness[3] << " " << sharpness[4];
  EXPECT_NEAR(c.sidecars[sharpest].settings["focus_distance_m"].get<double>(), target_m, 1e-9);
  EXPECT_TRUE(c.sidecars[0].settings["focus_distance_m"].is_null()) << "position 0 is infinity";
  EXPECT_LT(sharpness[1], sharpness[2]);
  EXPECT_LT(sharpness[3], sharpness[2]);
}

TEST(VirtualCapture, ApertureSeriesSignalFallsAsInverseFNumberSquared) {
  auto vcam = testing::open_virtual_camera(testing::capture_camera_json(2), grey_scene(),
                                           /*realtime=*/false);
  Captured c = capture(
      vcam,
      {{"kind", "aperture_series"}, {"f_numbers", {2, 2.8, 4, 5.6, 8}}, {"exposure_us", 2000}}, 2);
  ASSERT_FALSE(c.summary.failure.has_value()) << c.summary.failure->message;
  ASSERT_EQ(c.images.size(), 5u);
  std::vector<double> times_n2;
  for (size_t i = 0; i < c.images.size(); ++i) {
    const double n = c.sidecars[i].settings["f_number"].get<double>();
    EXPECT_EQ(n, c.sidecars[i].settings["requested"]["f_number"].get<double>());
    times_n2.push_back(signal_above_black(c.images[i], c.sidecars[i]) * n * n);
  }
  EXPECT_LT(signal_above_black(c.images[0], c.sidecars[0]) + 64, 0.9 * 4095) << "f/2 must not clip";
  for (double v : times_n2) EXPECT_NEAR(v / times_n2[0], 1.0, 0.02);
}

// Calls `fault` once, when the n-th frame has been written.
class FaultAfter : public CaptureObserver {
 public:
  FaultAfter(int frames, std::function<void()> fault) : frames_(frames), fault_(std::move(fault)) {}
  void on_frame(const image::CaptureFrameEntry&, const image::FrameSidecar&,
                const CaptureProgress& progress) override {
    if (progress.frames_kept == frames_) fault_();
  }

 private:
  int frames_;
  std::function<void()> fault_;
};

json long_bracket() {
  return {{"kind", "bracket"},
          {"exposures_us", {1000, 2000, 3000, 4000, 5000, 6000, 7000, 8000}},
          {"repeats", 4}};
}

TEST(VirtualCapture, UnplugMidRunFailsTheRunAndKeepsReadableFrames) {
  auto vcam = testing::open_virtual_camera(testing::capture_camera_json(1), grey_scene(),
                                           /*realtime=*/true);
  FaultAfter unplug(2, [&] { vcam.device->unplug(); });
  Captured c = capture(vcam, long_bracket(), 1, &unplug);
  ASSERT_TRUE(c.summary.failure.has_value());
  EXPECT_EQ(c.summary.failure->code, "no_device") << c.summary.failure->message;
  EXPECT_FALSE(c.complete);
  EXPECT_GE(c.images.size(), 2u);
  EXPECT_LT(c.images.size(), 32u);
  EXPECT_EQ(c.images.size(), static_cast<size_t>(c.summary.frames_kept));
  expect_signal_proportional_to_exposure(c, 0.02);
  EXPECT_TRUE(c.summary.restore_error.has_value()) << "a camera that is gone cannot be restored";
}

TEST(VirtualCapture, AnIoErrorMidRunFailsTheRunAndKeepsFrames) {
  auto vcam = testing::open_virtual_camera(testing::capture_camera_json(1), grey_scene(),
                                           /*realtime=*/true);
  FaultAfter fail(1, [&] { vcam.device->fail_next_dequeues(1); });
  Captured c = capture(vcam, long_bracket(), 1, &fail);
  ASSERT_TRUE(c.summary.failure.has_value());
  EXPECT_EQ(c.summary.failure->code, "io_error") << c.summary.failure->message;
  EXPECT_GE(c.images.size(), 1u);
  EXPECT_FALSE(c.summary.restore_error.has_value())
      << "the camera is still there: controls go back";
  EXPECT_EQ(*vcam.camera->get_control("exposure_time_absolute"), 10);
}

TEST(VirtualCapture, DroppedFramesCostFramesNotCorrectness) {
  auto vcam = testing::open_virtual_camera(testing::capture_camera_json(3), grey_scene(),
                                           /*realtime=*/true);
  FaultAfter drop(1, [&] { vcam.device->drop_next_frames(3); });
  Captured c = capture(vcam, long_bracket(), 3, &drop);
  ASSERT_FALSE(c.summary.failure.has_value()) << c.summary.failure->message;
  EXPECT_TRUE(c.complete);
  EXPECT_EQ(c.images.size(), 32u);
  EXPECT_GE(c.summary.frames_dropped, 3);
  expect_signal_proportional_to_exposure(c, 0.02);
}

}  // namespace
}  // namespace camlab::capture
