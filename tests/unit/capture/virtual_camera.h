// The virtual camera as a V4L2 device in process, opened through camlab's V4L2 backend
// (as tests/unit/device does), with the CameraTraits its spec gives; and a scratch folder.
#pragma once

#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>

#include "capture/capture_plan.h"
#include "device/v4l2/v4l2_camera.h"
#include "mock_device/v4l2/capture_traits.h"
#include "mock_device/v4l2/virtual_v4l2_io.h"
#include "test_specs.h"

namespace camlab::testing {

// 12-bit, black 64, f = 8 mm, 4 um pixels, an iris of whole and half stops, focus motor
// 1 um per step, 10 ms frames.
inline nlohmann::json capture_camera_json(int latency_frames, int width_px = 64,
                                          int height_px = 48) {
  nlohmann::json camera = mock::testing::pinhole_camera_json(width_px, height_px);
  camera["lens"]["iris"] = {{"f_numbers", {16, 11, 8, 5.6, 4, 2.8, 2, 1.4}}};
  camera["timing"] = {{"frame_interval_us", 10000}, {"control_latency_frames", latency_frames}};
  camera["controls"]["exposure_time_absolute"] = {{"min", 1}, {"max", 100}, {"default", 10}};
  camera["controls"]["gain"] = {{"min", 100}, {"max", 1600}, {"default", 100}, {"unity", 100}};
  camera["controls"]["iris_absolute"] = {{"default", 4}};
  return camera;
}

struct VirtualCamera {
  std::shared_ptr<mock::VirtualV4l2Device> device;
  std::shared_ptr<mock::VirtualV4l2Io> io;
  std::unique_ptr<device::V4l2Camera> camera;  // declared last: closed first
  capture::CameraTraits traits;
};

inline VirtualCamera open_virtual_camera(const nlohmann::json& camera_json,
                                         const nlohmann::json& scene_json, bool realtime) {
  auto camera = mock::parse_camera_spec(camera_json);
  auto scene = mock::parse_scene_spec(scene_json);
  if (!camera || !scene)
    throw std::runtime_error(!camera ? camera.error().message : scene.error().message);
  VirtualCamera v;
  v.traits = mock::capture_traits_of(*camera);
  mock::VirtualDeviceOptions options;
  options.realtime = realtime;
  auto device = mock::VirtualV4l2Device::create(std::move(*camera), std::move(*scene), options);
  if (!device) throw std::runtime_error(device.error().message);
  v.device = std::move(*device);
  v.io = std::make_shared<mock::VirtualV4l2Io>(std::vector{v.device});
  auto opened = device::V4l2Camera::open(v.io, "/dev/video0");
  if (!opened) throw std::runtime_error(opened.error().message);
  v.camera = std::move(*opened);
  return v;
}

// A fresh folder path under the temp directory (not created), removed on destruction.
class ScratchDir {
 public:
  explicit ScratchDir(const std::string& name) {
    static std::atomic<int> counter{0};
    path_ = std::filesystem::temp_directory_path() /
            ("camlab_capture_" + name + "_" + std::to_string(::getpid()) + "_" +
             std::to_string(counter++));
    std::filesystem::remove_all(path_);
  }
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& child) const { return path_ / child; }

 private:
  std::filesystem::path path_;
};

}  // namespace camlab::testing
