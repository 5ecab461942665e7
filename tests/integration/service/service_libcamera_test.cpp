// camlabd serving a camera through libcamera: under `camlab vcam run` the virtual camera
// is a UVC webcam to libcamera (docs/libcamera.md) and a V4L2 node at once. With
// --prefer-libcamera it is listed once, under libcamera, naming its V4L2 id; an exposure
// bracket through libcamera's requests is proportional to exposure; and it survives an
// unplug and replug (the V4L2 node witnesses the camera; a fresh libcamera camera manager
// finds it again).
//
// The frames are 8-bit (libcamera 0.0.3 offers R8, not Y16, of a 10-bit sensor), so the
// camera has read noise: 30 e- is about 0.6 of an 8-bit step, which dithers the
// quantisation so that the mean of the centre's 4800 pixels is not biased by rounding.
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <cstdio>

#include "capture_checks.h"
#include "vcam_launch.h"

namespace {

using namespace camlab::testing;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

constexpr const char* kNoisyCamera = R"json({
  "name": "camlabd libcamera camera",
  "sensor": {"width_px": 160, "height_px": 120, "pixel_pitch_um": 4.0, "bit_depth": 10, "black_level_dn": 32,
             "full_well_e": 12000, "read_noise_e": 30, "shot_noise": false, "quantum_efficiency": 0.65},
  "lens": {"focal_mm": 8.0, "f_number_min": 1.4, "f_number_max": 16.0,
           "iris": {"f_numbers": [16, 11, 8, 5.6, 4, 2.8, 2, 1.4]}},
  "timing": {"frame_interval_us": 20000, "control_latency_frames": 3},
  "controls": {"exposure_time_absolute": {"min": 1, "max": 200, "default": 10},
               "gain": {"min": 100, "max": 800, "default": 100, "unity": 100},
               "iris_absolute": {"default": 5}}
})json";

class ServiceLibcamera : public SharedDaemonSuite<ServiceLibcamera> {
 protected:
  static void SetUpTestSuite() {
    start_shared_daemon("libcamera", [](const fs::path& dir) {
      const std::string camera = (dir / "camera_noisy.json").string();
      std::ofstream(camera) << kNoisyCamera;
      return Launch{{"--no-virtual", "--prefer-libcamera", "--device-spec", camera,
                     "--frame-timeout-ms", "3000"},
                    vcam_prefix_saving_broker(dir, camera, (dir / "scene.json").string())};
    });
  }
  void SetUp() override {
#ifndef CAMLAB_HAVE_LIBCAMERA
    GTEST_SKIP() << "camlab is built without libcamera";
#endif
    SharedDaemonSuite<ServiceLibcamera>::SetUp();
  }
};

TEST_F(ServiceLibcamera, TheCameraIsListedOnceUnderLibcamera) {
  const json cameras = daemon_->get("/v1/cameras").json()["cameras"];
  ASSERT_EQ(cameras.size(), 1u) << cameras.dump(2) << daemon_->log();
  const json& c = cameras[0];
  EXPECT_EQ(c["backend"], "libcamera");
  EXPECT_EQ(c["transport"], "libcamera");
  // libcamera's UVC id: the controller's firmware path, the USB port, vendor:product.
  EXPECT_EQ(c["id"], "libcamera:\\_SB_.CAMLAB-1:1.0-1d6b:0102");
  EXPECT_EQ(c["also_reachable_as"], "v4l2:platform:camlab-vcam-0");
  EXPECT_EQ(c["name"], "camlabd libcamera camera");
  EXPECT_TRUE(c["available"].get<bool>()) << c.dump();
}

TEST_F(ServiceLibcamera, ABracketThroughLibcameraIsProportionalToExposure) {
  // No iris control through libcamera: the camera's default (f/2.8) stays.
  const double worst = check_bracket_is_linear(*daemon_, camera_, json::object(), -1);
  std::printf(
      "[ figures  ] libcamera 1/2/4/8 ms bracket: worst deviation of signal/exposure "
      "from the 1 ms frame's %.2f%%\n",
      100 * worst);
  const json jobs = daemon_->get("/v1/jobs?limit=1").json();
  ASSERT_FALSE(jobs["jobs"].empty());
  const json& job = jobs["jobs"][0];
  // The settle rule used libcamera's probed latency (UVC reports no exposure per frame).
  EXPECT_EQ(job["result"]["control_latency_source"], "probe") << job.dump();
  const DownloadedFrame first = download_frame(*daemon_, job["id"], 0);
  EXPECT_EQ(first.sidecar["delivered_format"], "GREY");
  EXPECT_EQ(first.sidecar["bit_depth"], 8);
  // What the pipeline reported with each frame is kept, never made up: libcamera 0.0.3's
  // UVC pipeline reports only the timestamp; a pipeline that reports the exposure must
  // report the one the sidecar claims.
  for (int i = 0; i < 4; ++i) {
    const json settings = download_frame(*daemon_, job["id"], i).sidecar["settings"];
    if (!settings.contains("reported") || !settings["reported"].contains("exposure_us")) continue;
    EXPECT_EQ(settings["in_effect_by"], "frame_report") << settings.dump();
    EXPECT_NEAR(settings["reported"]["exposure_us"].get<double>(),
                settings["exposure_us"].get<double>(),
                0.05 * settings["exposure_us"].get<double>());
  }
}

TEST_F(ServiceLibcamera, UnplugAndReplugAreFollowedThroughTheV4l2Node) {
  const std::string id = daemon_->camera_id();
  const pid_t pid = daemon_->pid();
  auto r = daemon_->post(camera_ + "/captures", {{"kind", "single"}, {"repeats", 100}});
  ASSERT_EQ(r.status, 202) << r.body;
  const int64_t job_id = r.json()["id"];
  daemon_->wait_job(job_id, [](const json& j) { return j["progress"]["frames_done"] >= 5; });
  const auto unplugged_at = Clock::now();
  const CliRun unplug = run_cli_with_broker(*dir_, "vcam fault unplug");
  ASSERT_EQ(unplug.exit_code, 0) << unplug.err;
  const json job = daemon_->wait_finished(job_id, 30s);
  const double lost_ms =
      std::chrono::duration<double, std::milli>(Clock::now() - unplugged_at).count();
  EXPECT_EQ(job["state"], "device_lost") << job.dump() << daemon_->log();
  const int done = job["progress"]["frames_done"];
  EXPECT_GE(done, 5);
  EXPECT_LT(done, 100);
  for (int i = 0; i < done; ++i)
    EXPECT_FALSE(download_frame(*daemon_, job_id, i).image.empty()) << "frame " << i;

  const auto replugged_at = Clock::now();
  const CliRun replug = run_cli_with_broker(*dir_, "vcam fault replug");
  ASSERT_EQ(replug.exit_code, 0) << replug.err;
  json back;
  for (const auto deadline = Clock::now() + 15s; Clock::now() < deadline;) {
    const json list = daemon_->get("/v1/cameras").json();
    if (list.is_object())
      for (const auto& c : list["cameras"])
        if (c["id"] == id) back = c;
    if (back.is_object() && back.value("present", false) && back.value("available", false)) break;
    std::this_thread::sleep_for(20ms);
  }
  const double back_ms =
      std::chrono::duration<double, std::milli>(Clock::now() - replugged_at).count();
  ASSERT_TRUE(back.is_object() && back.value("available", false))
      << back.dump() << daemon_->get("/v1/cameras").body << daemon_->log();
  std::printf(
      "[ figures  ] libcamera under vcam run: unplug -> job device_lost %.0f ms; replug "
      "-> available %.0f ms\n",
      lost_ms, back_ms);
  auto again = daemon_->post(camera_ + "/captures", {{"kind", "single"}, {"repeats", 3}});
  ASSERT_EQ(again.status, 202) << again.body;
  EXPECT_EQ(daemon_->wait_finished(again.json()["id"])["state"], "succeeded") << daemon_->log();
  EXPECT_EQ(daemon_->pid(), pid);
  EXPECT_EQ(::kill(pid, 0), 0);
}

}  // namespace
