// camlabd through the user-space V4L2 device: run under `camlab vcam run`, it finds
// /dev/video0 as a kernel camera would appear and drives it through the real V4L2
// backend and system calls (interposed by the preload library).
#include <gtest/gtest.h>

#include "capture_checks.h"

namespace {

using namespace camlab::testing;
using nlohmann::json;

class ServiceVcam : public SharedDaemonSuite<ServiceVcam> {
 protected:
  static void SetUpTestSuite() {
    start_shared_daemon("vcam", [](const fs::path& dir) {
      const std::string camera = (dir / "camera.json").string();
      return Launch{{"--no-virtual", "--device", "/dev/video0", "--device-spec", camera},
                    {CAMLAB_CLI_PATH, "vcam", "run", "--camera", camera, "--scene",
                     (dir / "scene.json").string(), "--"}};
    });
  }
};

TEST_F(ServiceVcam, TheUserSpaceDeviceIsServedAsAKernelCamera) {
  auto cameras = daemon_->get("/v1/cameras").json()["cameras"];
  ASSERT_EQ(cameras.size(), 1u) << cameras.dump();
  EXPECT_EQ(cameras[0]["transport"], "kernel");
  EXPECT_EQ(cameras[0]["path"], "/dev/video0");
  EXPECT_TRUE(cameras[0]["available"].get<bool>());
  auto camera = daemon_->get(camera_);
  ASSERT_EQ(camera.status, 200);
  EXPECT_FALSE(camera.json()["controls"].empty());
  EXPECT_EQ(http(daemon_->port(), "GET", camera_).status, 401);
}

TEST_F(ServiceVcam, OutOfRangeControlsGet422NamingTheRange) {
  auto r = daemon_->put(camera_ + "/controls", {{"exposure_time_absolute", 100000}});
  EXPECT_EQ(r.status, 422) << r.body;
  EXPECT_NE(r.body.find("[1, 200]"), std::string::npos) << r.body;
  EXPECT_EQ(daemon_->put(camera_ + "/controls", {{"exposure_time_absolute", 30}}).status, 200);
}

TEST_F(ServiceVcam, BracketSignalIsProportionalToExposure) {
  check_bracket_is_linear(*daemon_, camera_);
}

TEST_F(ServiceVcam, LatencyProbeFindsThreeFrames) {
  auto r = daemon_->post(camera_ + "/latency-probe", json::object());
  ASSERT_EQ(r.status, 202) << r.body;
  const json job = daemon_->wait_finished(r.json()["id"]);
  ASSERT_EQ(job["state"], "succeeded") << job.dump();
  EXPECT_EQ(job["result"]["control_latency_frames"], 3) << job.dump();
}

TEST_F(ServiceVcam, CancelAndFramesWork) {
  auto r = daemon_->post(camera_ + "/captures", {{"kind", "single"}, {"repeats", 60}});
  ASSERT_EQ(r.status, 202);
  const int64_t id = r.json()["id"];
  daemon_->wait_job(id, [](const json& j) { return j["progress"]["frames_done"].get<int>() >= 1; });
  EXPECT_EQ(daemon_->del("/v1/jobs/" + std::to_string(id)).status, 202);
  EXPECT_EQ(daemon_->wait_finished(id)["state"], "cancelled");
  const DownloadedFrame frame = download_frame(*daemon_, id, 0);
  EXPECT_EQ(frame.image.cols, 160);
  EXPECT_TRUE(frame.sidecar.contains("sequence"));
  EXPECT_EQ(daemon_->get("/metrics").status, 200);
  EXPECT_EQ(daemon_->get("/v1/openapi.json").status, 200);
}

}  // namespace
