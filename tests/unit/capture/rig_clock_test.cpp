// A virtual rig's cameras on one frame clock, through camlab's own V4L2 backend: every
// frame one trigger starts carries one timestamp in each camera (plus a camera's trigger
// offset), on the grid of the rig's frame interval, however late each stream started.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <set>
#include <thread>

#include "device/v4l2/v4l2_camera.h"
#include "mock_device/broker/vcam_devices.h"
#include "mock_device/spec/rig_spec.h"
#include "mock_device/v4l2/virtual_v4l2_io.h"
#include "test_specs.h"

namespace camlab::capture {
namespace {

namespace fs = std::filesystem;

// Two small 10 ms cameras, the second triggered 300 us after the first.
fs::path write_rig(const fs::path& dir) {
  nlohmann::json camera = mock::testing::pinhole_camera_json(64, 48);
  camera["timing"] = {{"frame_interval_us", 10000}, {"control_latency_frames", 1}};
  camera["controls"]["exposure_time_absolute"] = {{"min", 1}, {"max", 100}, {"default", 10}};
  const nlohmann::json rig = {
      {"scene", mock::testing::uniform_scene_json(1.0, 0.5)},
      {"cameras",
       {{{"camera", camera}, {"rt_cam_ref", {0, 0, 0, 0, 0, 0}}},
        {{"camera", camera}, {"rt_cam_ref", {0, 0, 0, -0.1, 0, 0}}, {"trigger_offset_us", 300}}}}};
  fs::create_directories(dir);
  std::ofstream(dir / "rig.json") << rig.dump();
  return dir / "rig.json";
}

std::vector<int64_t> stream_timestamps(device::Camera& camera, int frames) {
  std::vector<int64_t> stamps;
  EXPECT_TRUE(camera.start(4).ok());
  for (int i = 0; i < frames; ++i) {
    auto frame = camera.dequeue(std::chrono::milliseconds(2000));
    if (!frame) {
      ADD_FAILURE() << frame.error().message;
      break;
    }
    EXPECT_EQ(frame->meta.clock, "monotonic");
    stamps.push_back(frame->meta.timestamp_ns);
    EXPECT_TRUE(camera.requeue(*frame).ok());
  }
  EXPECT_TRUE(camera.stop().ok());
  return stamps;
}

TEST(RigClock, FramesOfOneTriggerShareATimestampPlusTheCamerasOffset) {
  const fs::path dir = fs::temp_directory_path() / ("camlab_rig_clock_" + std::to_string(getpid()));
  auto devices = mock::create_vcam_rig_devices(write_rig(dir).string(), true);
  fs::remove_all(dir);
  ASSERT_TRUE(devices.ok()) << devices.error().message;
  ASSERT_EQ(devices->size(), 2u);
  auto io = std::make_shared<mock::VirtualV4l2Io>(*devices);
  auto first = device::V4l2Camera::open(io, "/dev/video0");
  auto second = device::V4l2Camera::open(io, "/dev/video1");
  ASSERT_TRUE(first.ok()) << first.error().message;
  ASSERT_TRUE(second.ok()) << second.error().message;
  // The second stream starts 25 ms after the first, off any tick.
  std::vector<int64_t> a, b;
  std::thread first_stream([&] { a = stream_timestamps(**first, 20); });
  std::this_thread::sleep_for(std::chrono::milliseconds(25));
  b = stream_timestamps(**second, 12);
  first_stream.join();
  ASSERT_EQ(a.size(), 20u);
  ASSERT_EQ(b.size(), 12u);
  // Every timestamp of either camera on the grid (10 ms apart), and each of the second's
  // frames 300 us after one of the first's: the skew a rig view reports.
  const std::set<int64_t> first_stamps(a.begin(), a.end());
  int matched = 0;
  for (int64_t t : b) {
    const int64_t phase_ns = ((t - a[0]) % 10'000'000 + 10'000'000) % 10'000'000;
    EXPECT_NEAR(static_cast<double>(phase_ns), 300'000, 1'000) << "off the rig's grid";
    if (first_stamps.count(t - 300'000)) ++matched;
  }
  for (size_t i = 1; i < a.size(); ++i)
    EXPECT_EQ((a[i] - a[0]) % 10'000'000, 0) << "frame " << i << " off the grid";
  // Both streamed over the same 120 ms: most of the second's frames have their partner.
  EXPECT_GE(matched, 8);
}

}  // namespace
}  // namespace camlab::capture
