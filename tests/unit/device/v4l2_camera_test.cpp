// camlab's V4L2 backend against the virtual camera's V4L2 device, in process: the
// backend's real ioctl code (formats, controls, streaming, latency, faults) with only
// the system-call layer replaced (mock_device/v4l2/virtual_v4l2_io.h).
#include <gtest/gtest.h>
#include <linux/videodev2.h>

#include <algorithm>
#include <chrono>

#include <opencv2/core.hpp>

#include "device/v4l2/v4l2_camera.h"
#include "mock_device/v4l2/virtual_v4l2_io.h"
#include "test_specs.h"

namespace camlab {
namespace {

using namespace std::chrono_literals;

nlohmann::json test_camera_json(int latency_frames) {
  nlohmann::json camera = mock::testing::pinhole_camera_json(160, 120);
  camera["sensor"]["bit_depth"] = 10;
  camera["sensor"]["black_level_dn"] = 16;
  camera["sensor"]["read_noise_e"] = 0.0;
  camera["sensor"]["shot_noise"] = false;
  camera["timing"] = {{"frame_interval_us", 10000}, {"control_latency_frames", latency_frames}};
  camera["controls"]["exposure_time_absolute"] = {{"min", 1}, {"max", 100}, {"default", 10}};
  return camera;
}

class V4l2Backend : public ::testing::Test {
 protected:
  void SetUp() override { make_device(3, /*realtime=*/false); }

  void make_device(int latency_frames, bool realtime) {
    camera_.reset();
    io_.reset();
    auto camera = mock::parse_camera_spec(test_camera_json(latency_frames));
    auto scene = mock::parse_scene_spec(mock::testing::uniform_scene_json(1.0, 0.5));
    ASSERT_TRUE(camera.ok() && scene.ok());
    mock::VirtualDeviceOptions options;
    options.realtime = realtime;
    auto device = mock::VirtualV4l2Device::create(std::move(*camera), std::move(*scene), options);
    ASSERT_TRUE(device.ok()) << device.error().message;
    device_ = std::move(*device);
    io_ = std::make_shared<mock::VirtualV4l2Io>(std::vector{device_});
    auto opened = device::V4l2Camera::open(io_, "/dev/video0");
    ASSERT_TRUE(opened.ok()) << opened.error().message;
    camera_ = std::move(*opened);
  }

  // Mean signal above black of a Y16 frame (10-bit DN shifted up by 6), in DN.
  static double mean_dn(const device::Frame& frame, uint32_t width, uint32_t height) {
    cv::Mat image(static_cast<int>(height), static_cast<int>(width), CV_16UC1,
                  const_cast<uint8_t*>(frame.data));
    return cv::mean(image)[0] / 64.0 - 16.0;
  }

  std::shared_ptr<mock::VirtualV4l2Device> device_;
  std::shared_ptr<mock::VirtualV4l2Io> io_;
  std::unique_ptr<device::V4l2Camera> camera_;
};

TEST_F(V4l2Backend, IdentityAndFormats) {
  EXPECT_EQ(camera_->identity().driver, "camlab-vcam");
  EXPECT_EQ(camera_->identity().name, "test pinhole");
  EXPECT_EQ(camera_->identity().id, "v4l2:platform:camlab-vcam-0");
  auto formats = camera_->formats();
  ASSERT_TRUE(formats.ok()) << formats.error().message;
  ASSERT_EQ(formats->size(), 3u);
  EXPECT_EQ((*formats)[0].fourcc, "GREY");
  EXPECT_EQ((*formats)[1].fourcc, "Y16 ");
  EXPECT_EQ((*formats)[2].fourcc, "YUYV");
  for (const auto& f : *formats) {
    ASSERT_EQ(f.sizes.size(), 2u) << f.fourcc;
    EXPECT_EQ(f.sizes[0].width, 160u);
    EXPECT_EQ(f.sizes[1].height, 60u) << "2x2 binned";
    ASSERT_EQ(f.sizes[0].intervals.size(), 2u);
    EXPECT_NEAR(f.sizes[0].intervals[0].seconds(), 0.01, 1e-9);
  }
}

TEST_F(V4l2Backend, ControlsHaveTheSpecRangesAndUnits) {
  auto controls = camera_->controls();
  ASSERT_TRUE(controls.ok()) << controls.error().message;
  auto find = [&](const std::string& name) {
    auto it = std::find_if(controls->begin(), controls->end(),
                           [&](const auto& c) { return c.name == name; });
    EXPECT_NE(it, controls->end()) << name;
    return it == controls->end() ? device::ControlInfo{} : *it;
  };
  const auto exposure = find("exposure_time_absolute");
  EXPECT_EQ(exposure.minimum, 1);
  EXPECT_EQ(exposure.maximum, 100);
  EXPECT_EQ(exposure.current, 10);
  EXPECT_EQ(exposure.unit, "100 us");
  const auto mode = find("auto_exposure");
  ASSERT_EQ(mode.menu.size(), 2u);
  EXPECT_EQ(mode.menu[0].second, "Manual Mode");
  EXPECT_EQ(mode.menu[1].first, V4L2_EXPOSURE_APERTURE_PRIORITY);
  EXPECT_EQ(find("gain").maximum, 1600);
  EXPECT_EQ(find("focus_absolute").maximum, 2000);
  EXPECT_EQ(find("iris_absolute").maximum,
            static_cast<int64_t>(device_->camera().lens.iris.f_numbers.size() - 1));
  EXPECT_EQ(find("focus_automatic_continuous").type, device::ControlType::kBoolean);
}

TEST_F(V4l2Backend, SetControlReadsBackAndRefusesOutOfRange) {
  auto applied = camera_->set_control("gain", 250);
  ASSERT_TRUE(applied.ok()) << applied.error().message;
  EXPECT_EQ(*applied, 250);
  EXPECT_EQ(*camera_->get_control("gain"), 250);
  auto refused = camera_->set_control("exposure_time_absolute", 5000);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, "out_of_range");
  EXPECT_NE(refused.error().message.find("[1, 100] (100 us)"), std::string::npos)
      << refused.error().message;
  EXPECT_EQ(camera_->set_control("no_such_control", 1).error().code, "unknown_control");
}

TEST_F(V4l2Backend, ManualExposureSwitchesAutoExposureOff) {
  ASSERT_TRUE(camera_->set_control("auto_exposure", V4L2_EXPOSURE_APERTURE_PRIORITY).ok());
  auto controls = camera_->controls();
  auto exposure = std::find_if(controls->begin(), controls->end(),
                               [](const auto& c) { return c.name == "exposure_time_absolute"; });
  EXPECT_TRUE(exposure->inactive) << "a manual value is ignored under auto exposure";
  ASSERT_TRUE(camera_->set_control("exposure_time_absolute", 20).ok());
  EXPECT_EQ(*camera_->get_control("auto_exposure"), V4L2_EXPOSURE_MANUAL);
}

TEST_F(V4l2Backend, StreamsTheRenderersFramesInOrder) {
  device::StreamFormat want;
  want.fourcc = "GREY";
  want.width = 160;
  want.height = 120;
  auto format = camera_->configure(want);
  ASSERT_TRUE(format.ok()) << format.error().message;
  EXPECT_EQ(format->size_bytes, 160u * 120u);
  ASSERT_TRUE(camera_->start(4).ok());
  // The expected frame: the renderer's DN (noise off) reduced to 8 bits.
  mock::Renderer reference = mock::testing::make_renderer(
      test_camera_json(3), mock::testing::uniform_scene_json(1.0, 0.5));
  mock::RenderSettings settings = reference.default_settings();
  mock::RenderOptions options;
  auto expected = reference.render(settings, 0, options);
  ASSERT_TRUE(expected.ok());
  int64_t previous_ns = 0;
  for (int i = 0; i < 8; ++i) {
    auto frame = camera_->dequeue(2000ms);
    ASSERT_TRUE(frame.ok()) << frame.error().message;
    EXPECT_EQ(frame->meta.sequence, static_cast<uint64_t>(i));
    EXPECT_EQ(frame->meta.clock, "monotonic");
    EXPECT_GT(frame->meta.timestamp_ns, previous_ns);
    previous_ns = frame->meta.timestamp_ns;
    ASSERT_EQ(frame->size, 160u * 120u);
    cv::Mat got(120, 160, CV_8UC1, const_cast<uint8_t*>(frame->data));
    cv::Mat want8;
    expected->image.convertTo(want8, CV_8U, 1.0 / 4);  // 10 -> 8 bits
    EXPECT_LE(cv::norm(got, want8, cv::NORM_INF), 1) << "frame " << i;
    ASSERT_TRUE(camera_->requeue(*frame).ok());
  }
  ASSERT_TRUE(camera_->stop().ok());
  EXPECT_EQ(camera_->mapped_buffer_count(), 0u);
}

TEST_F(V4l2Backend, ANewExposureShowsExactlyLatencyFramesLater) {
  ASSERT_TRUE(camera_->configure({"Y16", 160, 120}).ok());
  ASSERT_TRUE(
      camera_->set_control("exposure_time_absolute", 30).ok());  // before streaming: at once
  ASSERT_TRUE(camera_->start(3).ok());
  // Hold all three buffers: the device (paced by buffers, not by a clock, in this test)
  // then waits with frame 3 next to start, so the frame a new value lands in is known.
  std::vector<device::Frame> held;
  for (int i = 0; i < 3; ++i) {
    auto frame = camera_->dequeue(2000ms);
    ASSERT_TRUE(frame.ok()) << frame.error().message;
    EXPECT_EQ(frame->meta.sequence, static_cast<uint64_t>(i));
    held.push_back(*frame);
  }
  const double base = mean_dn(held[0], 160, 120);
  ASSERT_TRUE(camera_->set_control("exposure_time_absolute", 60).ok());  // 3 -> 6 ms: double
  for (const auto& frame : held) ASSERT_TRUE(camera_->requeue(frame).ok());
  // Latency 3: frames 3, 4, 5 were already on their way; frame 6 has the new exposure.
  for (uint64_t expected = 3; expected < 10; ++expected) {
    auto frame = camera_->dequeue(2000ms);
    ASSERT_TRUE(frame.ok());
    ASSERT_EQ(frame->meta.sequence, expected);
    const double ratio = mean_dn(*frame, 160, 120) / base;
    EXPECT_NEAR(ratio, expected >= 6 ? 2.0 : 1.0, 0.01) << "frame " << expected;
    ASSERT_TRUE(camera_->requeue(*frame).ok());
  }
}

TEST_F(V4l2Backend, DroppedFramesAreReportedAsSequenceGaps) {
  ASSERT_TRUE(camera_->start(3).ok());
  auto frame = camera_->dequeue(2000ms);
  ASSERT_TRUE(frame.ok());
  ASSERT_TRUE(camera_->requeue(*frame).ok());
  device_->drop_next_frames(2);
  // Buffers already filled come first; keep dequeuing until the gap shows.
  uint64_t dropped = 0;
  for (int i = 0; i < 6 && dropped == 0; ++i) {
    auto next = camera_->dequeue(2000ms);
    ASSERT_TRUE(next.ok());
    dropped = next->meta.dropped_before;
    ASSERT_TRUE(camera_->requeue(*next).ok());
  }
  EXPECT_EQ(dropped, 2u);
}

TEST_F(V4l2Backend, DequeueErrorIsReportedAndStreamingContinues) {
  ASSERT_TRUE(camera_->start(3).ok());
  device_->fail_next_dequeues(1);
  auto failed = camera_->dequeue(2000ms);
  ASSERT_FALSE(failed.ok());
  EXPECT_EQ(failed.error().code, "io_error");
  EXPECT_NE(failed.error().message.find("VIDIOC_DQBUF"), std::string::npos);
  auto next = camera_->dequeue(2000ms);
  EXPECT_TRUE(next.ok()) << next.error().message;
}

TEST_F(V4l2Backend, AStalledCameraTimesOut) {
  ASSERT_TRUE(camera_->start(3).ok());
  ASSERT_TRUE(camera_->dequeue(2000ms).ok());  // buffers 1 and 2 may already be full
  device_->stall(true);
  Result<device::Frame> frame = make_error("internal", "not run yet");
  for (int i = 0; i < 4 && frame.ok() == false && frame.error().code == "internal"; ++i)
    frame = camera_->dequeue(100ms);
  for (int i = 0; i < 4 && frame.ok(); ++i) frame = camera_->dequeue(100ms);
  ASSERT_FALSE(frame.ok());
  EXPECT_EQ(frame.error().code, "timeout");
  device_->stall(false);
}

TEST_F(V4l2Backend, UnplugMidStreamIsAClearErrorAndLeaksNothing) {
  ASSERT_TRUE(camera_->start(4).ok());
  ASSERT_TRUE(camera_->dequeue(2000ms).ok());
  EXPECT_EQ(io_->mapping_count(), 4u);
  device_->unplug();
  auto frame = camera_->dequeue(2000ms);
  // Either a buffer completed before the unplug, or the camera is gone: never a hang.
  for (int i = 0; i < 5 && frame.ok(); ++i) frame = camera_->dequeue(2000ms);
  ASSERT_FALSE(frame.ok());
  EXPECT_EQ(frame.error().code, "no_device") << frame.error().message;
  EXPECT_EQ(camera_->set_control("gain", 200).error().code, "no_device");
  camera_.reset();  // stop + unmap + close, despite the device being gone
  EXPECT_EQ(io_->mapping_count(), 0u);
  EXPECT_EQ(io_->open_fd_count(), 0u);
}

TEST_F(V4l2Backend, ASecondOpenCannotTakeTheStream) {
  ASSERT_TRUE(camera_->start(3).ok());
  auto other = device::V4l2Camera::open(io_, "/dev/video0");
  ASSERT_TRUE(other.ok());
  auto status = (*other)->start(3);
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.error().code, "busy");
  EXPECT_TRUE((*other)->get_control("gain").ok()) << "controls stay available to every open";
}

TEST_F(V4l2Backend, ARealtimePacedDeviceStreamsInSequence) {
  make_device(0, /*realtime=*/true);
  ASSERT_TRUE(camera_->start(4).ok());
  uint64_t previous = 0;
  for (int i = 0; i < 6; ++i) {
    auto frame = camera_->dequeue(2000ms);
    ASSERT_TRUE(frame.ok()) << frame.error().message;
    if (i > 0) {
      EXPECT_GT(frame->meta.sequence, previous);
    }
    previous = frame->meta.sequence;
    ASSERT_TRUE(camera_->requeue(*frame).ok());
  }
}

// A rig member's clock: each buffer is stamped on its frame's tick, so timestamps and
// sequence numbers tell the same story, dropped frames included (the first buffer's time
// plus sequence x the 10 ms interval, within 1 ms).
TEST_F(V4l2Backend, TimestampsAreSequenceTimesTheIntervalWithFramesDropped) {
  make_device(0, /*realtime=*/true);
  ASSERT_TRUE(camera_->start(4).ok());
  int64_t first_ns = -1;
  uint64_t first_sequence = 0, gaps = 0;
  for (int i = 0; i < 14; ++i) {
    if (i == 4) device_->drop_next_frames(3);
    auto frame = camera_->dequeue(2000ms);
    ASSERT_TRUE(frame.ok()) << frame.error().message;
    if (first_ns < 0) {
      first_ns = frame->meta.timestamp_ns;
      first_sequence = frame->meta.sequence;
    }
    gaps += frame->meta.dropped_before;
    const int64_t expected_ns =
        first_ns + static_cast<int64_t>(frame->meta.sequence - first_sequence) * 10'000'000;
    EXPECT_NEAR(static_cast<double>(frame->meta.timestamp_ns - expected_ns), 0.0, 1e6)
        << "sequence " << frame->meta.sequence;
    ASSERT_TRUE(camera_->requeue(*frame).ok());
  }
  EXPECT_GE(gaps, 3u) << "the dropped frames show as sequence gaps";
}

TEST(V4l2BackendOpen, MissingDeviceIsNoDevice) {
  auto io = std::make_shared<mock::VirtualV4l2Io>(
      std::vector<std::shared_ptr<mock::VirtualV4l2Device>>{});
  auto camera = device::V4l2Camera::open(io, "/dev/video7");
  ASSERT_FALSE(camera.ok());
  EXPECT_EQ(camera.error().code, "no_device");
}

}  // namespace
}  // namespace camlab
