// The latency probe on the virtual camera returns the latency its spec says, restores
// the exposure, and refuses to guess in the dark.
#include "capture/latency_probe.h"

#include <gtest/gtest.h>
#include <linux/videodev2.h>

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
