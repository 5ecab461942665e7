// The latency probe on the virtual camera returns the latency its spec says, restores
// the exposure, and refuses to guess in the dark.
#include "capture/latency_probe.h"

#include <gtest/gtest.h>
#include <linux/videodev2.h>

#include <chrono>
#include <thread>
#include <vector>

#include "hooked_camera.h"
#include "virtual_camera.h"

namespace camlab::capture {
namespace {

class LatencyProbe : public ::testing::TestWithParam<std::tuple<int, bool>> {};

TEST_P(LatencyProbe, FindsTheSpecLatency) {
  const auto [latency, realtime] = GetParam();
  auto vcam = testing::open_virtual_camera(testing::capture_camera_json(latency),
                                           mock::testing::uniform_scene_json(1.0, 0.5), realtime);
  ASSERT_TRUE(vcam.camera->set_control("auto_exposure", V4L2_EXPOSURE_APERTURE_PRIORITY).ok());
  auto result = probe_control_latency(*vcam.camera, 3, 8);
  ASSERT_TRUE(result.ok()) << result.error().code << ": " << result.error().message;
  EXPECT_EQ(result->latency_frames, latency);
  EXPECT_EQ(result->repetitions, 3);
  EXPECT_EQ(result->agreeing, 3);
  // Every frame seen is in the trace; frames the device skipped (a loaded machine) are not.
  EXPECT_LE(static_cast<int>(result->mean_dn_trace.size()), result->frames_consumed);
  EXPECT_GE(static_cast<int>(result->mean_dn_trace.size()), 3 * (latency + 1));
  EXPECT_EQ(*vcam.camera->get_control("exposure_time_absolute"), 10);
  EXPECT_EQ(*vcam.camera->get_control("auto_exposure"), V4L2_EXPOSURE_APERTURE_PRIORITY);
}

INSTANTIATE_TEST_SUITE_P(SpecLatency, LatencyProbe,
                         ::testing::Values(std::make_tuple(0, false), std::make_tuple(1, false),
                                           std::make_tuple(3, false), std::make_tuple(3, true)));

// Bright enough that the first two exposures (the current one and half of it) are the
// plateaus: the probe's 1st and 2nd writes, its 3rd the first step.
nlohmann::json bright_scene() {
  auto scene = mock::testing::uniform_scene_json(1.0, 0.5);
  scene["illuminance_lux"] = 4000;
  return scene;
}

// The client's thread preempted between the write and its clock read: frames start in
// between (on the real-time clock, 10 ms apart, into buffers the probe has queued), which
// the device counts as after the write and the probe cannot place. Stalled there, the
// first step would read one frame short (0 for 1) unless it is measured again.
TEST(LatencyProbeRaces, AStepWhoseFrameStartedDuringTheWriteIsMeasuredAgain) {
  auto vcam = testing::open_virtual_camera(testing::capture_camera_json(1), bright_scene(), true);
  std::vector<int64_t> written;
  testing::HookedCamera preempted(*vcam.camera, {},
                                  [&](const std::string& name, int64_t value, int n) {
                                    if (name != "exposure_time_absolute") return;
                                    written.push_back(value);
                                    if (n == 3)
                                      std::this_thread::sleep_for(std::chrono::milliseconds(25));
                                  });
  auto result = probe_control_latency(preempted, 3, 8);
  ASSERT_TRUE(result.ok()) << result.error().code << ": " << result.error().message;
  ASSERT_GE(written.size(), 3u);
  ASSERT_EQ(written[2], written[0]) << "the stalled write was not the first step up";
  EXPECT_EQ(result->latency_frames, 1);
  EXPECT_EQ(result->agreeing, 3);
  EXPECT_EQ(result->repetitions, 3);
}

// Every step's write that slow: no step can be placed, and the probe says so rather than
// guess.
TEST(LatencyProbeRaces, WritesSlowerThanAFrameAreInconclusive) {
  auto vcam = testing::open_virtual_camera(testing::capture_camera_json(1), bright_scene(), true);
  testing::HookedCamera slow(*vcam.camera, {}, [](const std::string& name, int64_t, int n) {
    if (name == "exposure_time_absolute" && n >= 3)
      std::this_thread::sleep_for(std::chrono::milliseconds(25));
  });
  auto result = probe_control_latency(slow, 3, 8);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.error().code, "inconclusive") << result.error().message;
  EXPECT_NE(result.error().message.find("being written"), std::string::npos)
      << result.error().message;
  EXPECT_EQ(*vcam.camera->get_control("exposure_time_absolute"), 10);
}

TEST(LatencyProbeErrors, ADarkSceneIsInconclusive) {
  auto vcam = testing::open_virtual_camera(testing::capture_camera_json(2),
                                           mock::testing::uniform_scene_json(1.0, 0.0), false);
  auto result = probe_control_latency(*vcam.camera, 3, 4);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.error().code, "inconclusive") << result.error().message;
  EXPECT_EQ(*vcam.camera->get_control("exposure_time_absolute"), 10);
}

TEST(LatencyProbeErrors, ALatencyBeyondTheLimitIsInconclusive) {
  auto vcam = testing::open_virtual_camera(testing::capture_camera_json(5),
                                           mock::testing::uniform_scene_json(1.0, 0.5), false);
  auto result = probe_control_latency(*vcam.camera, 3, 2);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.error().code, "inconclusive") << result.error().message;
}

}  // namespace
}  // namespace camlab::capture
