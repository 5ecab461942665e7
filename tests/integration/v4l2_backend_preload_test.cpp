// camlab's V4L2 backend against the user-space V4L2 device, across processes: this test
// process talks to the device only through libc (system_v4l2_io), the preload library and
// the broker of a `camlab vcam run`, exactly as it would talk to a kernel driver. Faults
// are injected through the broker (`camlab vcam fault`'s channel).
//
// main() re-runs this executable under `camlab vcam run --unpaced` with the test camera
// (written to a temporary file), so every ctest case gets a fresh device.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "device/v4l2/v4l2_camera.h"
#include "device/v4l2/v4l2_io.h"
#include "mock_device/broker/broker_protocol.h"
#include "suite_main.h"
#include "test_specs.h"

namespace camlab {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using mock::broker::Fault;

nlohmann::json test_camera_json() {
  nlohmann::json camera = mock::testing::pinhole_camera_json(160, 120);
  camera["sensor"]["bit_depth"] = 10;
  camera["sensor"]["black_level_dn"] = 16;
  camera["sensor"]["read_noise_e"] = 0.0;
  camera["sensor"]["shot_noise"] = false;
  camera["timing"] = {{"frame_interval_us", 10000}, {"control_latency_frames", 3}};
  camera["controls"]["exposure_time_absolute"] = {{"min", 1}, {"max", 100}, {"default", 10}};
  return camera;
}
nlohmann::json test_scene_json() { return mock::testing::uniform_scene_json(1.0, 0.5); }

void inject(Fault fault, int count = 1) {
  ASSERT_EQ(mock::broker::inject_fault(std::getenv("CAMLAB_VCAM_BROKER"), 0, fault, count), 0);
}

// Open fds and buffer mappings of this process, from /proc: leaks show here whatever
// layer leaked them.
size_t open_fd_count() {
  size_t n = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator("/proc/self/fd")) ++n;
  return n;
}
size_t buffer_mapping_count() {
  std::ifstream maps("/proc/self/maps");
  size_t n = 0;
  for (std::string line; std::getline(maps, line);)
    n += line.find("memfd:camlab-vcam-buffer") != std::string::npos;
  return n;
}

double mean_dn_y16(const device::Frame& frame) {
  cv::Mat image(120, 160, CV_16UC1, const_cast<uint8_t*>(frame.data));
  return cv::mean(image)[0] / 64.0 - 16.0;
}

class V4l2BackendThroughPreload : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_NE(std::getenv("CAMLAB_VCAM_BROKER"), nullptr)
        << "run under camlab vcam run (main does)";
    fds_before_ = open_fd_count();
    auto opened = device::V4l2Camera::open(device::system_v4l2_io(), "/dev/video0");
    ASSERT_TRUE(opened.ok()) << opened.error().message;
    camera_ = std::move(*opened);
  }
  std::unique_ptr<device::V4l2Camera> camera_;
  size_t fds_before_ = 0;
};

TEST_F(V4l2BackendThroughPreload, FormatsAndControlsWithTheirRangesAndUnits) {
  EXPECT_EQ(camera_->identity().backend, "v4l2");
  auto formats = camera_->formats();
  ASSERT_TRUE(formats.ok()) << formats.error().message;
  std::vector<std::string> fourccs;
  for (const auto& f : *formats) fourccs.push_back(f.fourcc);
  EXPECT_EQ(fourccs, (std::vector<std::string>{"GREY", "Y16 ", "YUYV"}));
  ASSERT_FALSE(formats->front().sizes.empty());
  EXPECT_EQ(formats->front().sizes.front().width, 160u);
  auto controls = camera_->controls();
  ASSERT_TRUE(controls.ok()) << controls.error().message;
  bool found = false;
  for (const auto& c : *controls) {
    if (c.name != "exposure_time_absolute") continue;
    found = true;
    EXPECT_EQ(c.minimum, 1);
    EXPECT_EQ(c.maximum, 100);
    EXPECT_EQ(c.unit, "100 us");
  }
  EXPECT_TRUE(found);
  auto applied = camera_->set_control("exposure_time_absolute", 42);
  ASSERT_TRUE(applied.ok());
  EXPECT_EQ(*applied, 42);
  auto refused = camera_->set_control("exposure_time_absolute", 1000);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, "out_of_range");
}

TEST_F(V4l2BackendThroughPreload, StreamsTheRenderersFramesAndANewExposureLandsLatencyFramesLater) {
  ASSERT_TRUE(camera_->configure({"Y16", 160, 120}).ok());
  ASSERT_TRUE(camera_->set_control("exposure_time_absolute", 30).ok());
  ASSERT_TRUE(camera_->start(3).ok());
  mock::Renderer reference = mock::testing::make_renderer(test_camera_json(), test_scene_json());
  mock::RenderSettings settings = reference.default_settings();
  settings.exposure_us = 3000;
  auto expected = reference.render(settings, 0, mock::RenderOptions{});
  ASSERT_TRUE(expected.ok());
  // Unpaced: the device waits for buffers, so holding all three fixes which frame is
  // next to start when the exposure changes.
  std::vector<device::Frame> held;
  for (int i = 0; i < 3; ++i) {
    auto frame = camera_->dequeue(5000ms);
    ASSERT_TRUE(frame.ok()) << frame.error().message;
    EXPECT_EQ(frame->meta.sequence, static_cast<uint64_t>(i));
    cv::Mat got(120, 160, CV_16UC1, const_cast<uint8_t*>(frame->data));
    cv::Mat got_dn;
    got.convertTo(got_dn, CV_64F, 1.0 / 64);  // Y16 holds the 10-bit DN << 6
    cv::Mat want_dn;
    expected->image.convertTo(want_dn, CV_64F);
    EXPECT_LE(cv::norm(got_dn, want_dn, cv::NORM_INF), 0.0)
        << "frame " << i << " is the renderer's image";
    held.push_back(*frame);
  }
  const double base = mean_dn_y16(held[0]);
  ASSERT_TRUE(camera_->set_control("exposure_time_absolute", 60).ok());  // double
  for (const auto& frame : held) ASSERT_TRUE(camera_->requeue(frame).ok());
  for (uint64_t sequence = 3; sequence < 9; ++sequence) {
    auto frame = camera_->dequeue(5000ms);
    ASSERT_TRUE(frame.ok()) << frame.error().message;
    ASSERT_EQ(frame->meta.sequence, sequence);
    EXPECT_NEAR(mean_dn_y16(*frame) / base, sequence >= 6 ? 2.0 : 1.0, 0.01)
        << "frame " << sequence;
    ASSERT_TRUE(camera_->requeue(*frame).ok());
  }
  ASSERT_TRUE(camera_->stop().ok());
  EXPECT_EQ(buffer_mapping_count(), 0u);
}

TEST_F(V4l2BackendThroughPreload, DroppedFramesAreSequenceGaps) {
  ASSERT_TRUE(camera_->start(3).ok());
  auto first = camera_->dequeue(5000ms);
  ASSERT_TRUE(first.ok());
  ASSERT_TRUE(camera_->requeue(*first).ok());
  inject(Fault::kDropFrames, 2);
  uint64_t dropped = 0;
  for (int i = 0; i < 6 && dropped == 0; ++i) {
    auto next = camera_->dequeue(5000ms);
    ASSERT_TRUE(next.ok()) << next.error().message;
    dropped = next->meta.dropped_before;
    ASSERT_TRUE(camera_->requeue(*next).ok());
  }
  EXPECT_EQ(dropped, 2u);
}

TEST_F(V4l2BackendThroughPreload, ADequeueErrorIsReportedAndStreamingContinues) {
  ASSERT_TRUE(camera_->start(3).ok());
  inject(Fault::kDequeueEio, 1);
  auto failed = camera_->dequeue(5000ms);
  ASSERT_FALSE(failed.ok());
  EXPECT_EQ(failed.error().code, "io_error");
  auto next = camera_->dequeue(5000ms);
  EXPECT_TRUE(next.ok()) << next.error().message;
}

TEST_F(V4l2BackendThroughPreload, AStalledCameraTimesOut) {
  ASSERT_TRUE(camera_->start(3).ok());
  ASSERT_TRUE(camera_->dequeue(5000ms).ok());
  inject(Fault::kStall);
  Result<device::Frame> frame = camera_->dequeue(200ms);
  for (int i = 0; i < 4 && frame.ok(); ++i)
    frame = camera_->dequeue(200ms);  // buffers filled before the stall
  ASSERT_FALSE(frame.ok());
  EXPECT_EQ(frame.error().code, "timeout");
  inject(Fault::kResume);
}

TEST_F(V4l2BackendThroughPreload, ASecondOpenCannotTakeTheStream) {
  ASSERT_TRUE(camera_->start(3).ok());
  auto other = device::V4l2Camera::open(device::system_v4l2_io(), "/dev/video0");
  ASSERT_TRUE(other.ok());
  auto status = (*other)->start(3);
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.error().code, "busy");
}

// Last in the file: the device stays unplugged for the rest of the process.
TEST_F(V4l2BackendThroughPreload, UnplugMidStreamIsAClearErrorAndLeaksNoFdOrMapping) {
  ASSERT_TRUE(camera_->start(4).ok());
  ASSERT_TRUE(camera_->dequeue(5000ms).ok());
  EXPECT_EQ(buffer_mapping_count(), 4u);
  inject(Fault::kUnplug);
  auto frame = camera_->dequeue(2000ms);
  for (int i = 0; i < 5 && frame.ok(); ++i) frame = camera_->dequeue(2000ms);
  ASSERT_FALSE(frame.ok());
  EXPECT_EQ(frame.error().code, "no_device") << frame.error().message;
  EXPECT_EQ(camera_->set_control("gain", 200).error().code, "no_device");
  camera_.reset();
  EXPECT_EQ(buffer_mapping_count(), 0u);
  EXPECT_EQ(open_fd_count(), fds_before_);
  auto reopened = device::V4l2Camera::open(device::system_v4l2_io(), "/dev/video0");
  ASSERT_FALSE(reopened.ok());
  EXPECT_EQ(reopened.error().code, "no_device");
}

// Runs this executable again under `camlab vcam run` with the test camera and scene.
int rerun_under_vcam(int argc, char** argv) {
  const fs::path dir =
      fs::temp_directory_path() / ("camlab_backend_preload_" + std::to_string(getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "camera.json") << test_camera_json().dump();
  std::ofstream(dir / "scene.json") << test_scene_json().dump();
  const std::string camera = (dir / "camera.json").string(), scene = (dir / "scene.json").string();
  std::vector<std::string> args = {
      CAMLAB_CLI_PATH, "vcam",    "run", "--unpaced", "--camera",
      camera,          "--scene", scene, "--",        fs::read_symlink("/proc/self/exe").string()};
  for (int i = 1; i < argc; ++i) args.push_back(argv[i]);
  std::vector<char*> raw;
  for (auto& a : args) raw.push_back(a.data());
  raw.push_back(nullptr);
  const pid_t child = fork();
  if (child == 0) {
    execv(raw[0], raw.data());
    _exit(127);
  }
  int status = 1;
  while (waitpid(child, &status, 0) < 0 && errno == EINTR) {
  }
  fs::remove_all(dir);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 1;
}

}  // namespace
}  // namespace camlab

int main(int argc, char** argv) {
  if (!std::getenv("CAMLAB_VCAM_BROKER")) return camlab::rerun_under_vcam(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  return camlab::testing::run_all_tests_and_summarise();
}
