// libcamera against the virtual camera, inside `camlab vcam run`: libcamera's own tools
// (cam -l, cam --capture), v4l2-compliance on the media node, and camlab's libcamera
// backend (enumerate, controls, an exposure bracket) all see the virtual camera as a
// UVC webcam: the broker serves /dev/media0 (mock_device/v4l2/virtual_media_device.h) and the
// preload routes it and the fake sysfs (mock_device/v4l2/fake_sysfs.h) in every process.
//
// camlab's backend runs in a child process under `camlab vcam run` (this executable,
// started with --libcamera-child), which prints what it measured as JSON; the checks
// are made here against the truth: the exposures asked for, the renderer's images.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "cli_runner.h"
#ifdef CAMLAB_HAVE_LIBCAMERA
#include "device/device_registry.h"
#include "device/libcamera/libcamera_camera.h"
#include "suite_main.h"
#endif

namespace {

namespace fs = std::filesystem;
using camlab::testing::run_cli;

// Noise-free, so every frame is exactly the renderer's image; 50 frames per second.
constexpr const char* kCamera = R"({
  "name": "vcam libcamera test",
  "sensor": {"width_px": 160, "height_px": 120, "pixel_pitch_um": 4.0, "bit_depth": 10,
             "black_level_dn": 16, "full_well_e": 12000, "read_noise_e": 0, "shot_noise": false},
  "lens": {"focal_mm": 8.0, "f_number_min": 2.0, "f_number_max": 16.0},
  "timing": {"frame_interval_us": 20000, "control_latency_frames": 2},
  "controls": {"exposure_time_absolute": {"min": 1, "max": 200, "default": 50}}})";

#ifdef CAMLAB_HAVE_LIBCAMERA
std::string self_executable() {
  char path[PATH_MAX];
  const ssize_t n = readlink("/proc/self/exe", path, sizeof path - 1);
  return n > 0 ? std::string(path, static_cast<size_t>(n)) : std::string();
}
#endif

class Libcamera : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fs::temp_directory_path() /
          ("camlab_libcamera_" + std::to_string(::getpid()) + "_" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
    fs::create_directories(dir);
    std::ofstream(dir / "camera.json") << kCamera;
    std::ofstream(dir / "edge.json") << R"({"illuminance_lux": 1000,
      "targets": [{"type": "slanted_edge", "size_m": [1, 1], "angle_deg": 5, "pose": {"position_m": [0, 0, 2.0]}}]})";
    std::ofstream(dir / "uniform.json")
        << R"({"illuminance_lux": 1000, "background_reflectance": 0.5,
      "targets": [{"type": "uniform", "size_m": [10, 10], "light_reflectance": 0.5,
                   "pose": {"position_m": [0, 0, 1.0]}}]})";
    if (!fs::exists("/usr/bin/media-ctl")) GTEST_SKIP() << "media-ctl (v4l-utils) is not installed";
    // The broker serves the media node to every process: libcamera finds cameras only
    // through it.
    auto probe = run_cli(vcam("edge.json") + "media-ctl -d /dev/media0 -p");
    ASSERT_EQ(probe.exit_code, 0) << "media-ctl -d /dev/media0 -p: " << probe.err << probe.out;
    ASSERT_NE(probe.out.find("uvcvideo"), std::string::npos) << probe.out;
  }
  void TearDown() override { fs::remove_all(dir); }

  std::string vcam(const std::string& scene, int count = 1) const {
    return "vcam run --count " + std::to_string(count) + " --camera " +
           (dir / "camera.json").string() + " --scene " + (dir / scene).string() + " -- ";
  }

  fs::path dir;
};

TEST_F(Libcamera, CamListsTheVirtualCameraAsAUvcCamera) {
  if (!fs::exists("/usr/bin/cam")) GTEST_SKIP() << "cam (libcamera-tools) is not installed";
  auto run = run_cli(vcam("edge.json") + "cam -l");
  ASSERT_EQ(run.exit_code, 0) << run.err << run.out;
  EXPECT_NE(run.out.find("'vcam libcamera test'"), std::string::npos) << run.out;
  // The UVC pipeline's id: controller firmware path, USB port path, vendor:product.
  EXPECT_NE(run.out.find("(\\_SB_.CAMLAB-1:1.0-1d6b:0102)"), std::string::npos) << run.out;
}

TEST_F(Libcamera, CamCapturesTenFramesThatAreTheRenderersImages) {
  if (!fs::exists("/usr/bin/cam")) GTEST_SKIP() << "cam (libcamera-tools) is not installed";
  const fs::path frames = dir / "frames";
  fs::create_directories(frames);
  // The first format the UVC pipeline offers is R8 (GREY) at the full 160x120.
  auto run = run_cli(vcam("edge.json") +
                     "cam -c 1 --capture=10 --file=" + (frames / "frame-#.bin").string());
  ASSERT_EQ(run.exit_code, 0) << run.err << run.out;
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(frames)) files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  ASSERT_EQ(files.size(), 10u) << run.out;

  auto render = run_cli("render --camera " + (dir / "camera.json").string() + " --scene " +
                        (dir / "edge.json").string() + " --no-noise --quiet --out " +
                        (dir / "expected").string());
  ASSERT_EQ(render.exit_code, 0) << render.err;
  cv::Mat expected_dn =
      cv::imread((dir / "expected/frame_000000.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(expected_dn.type(), CV_16UC1);
  for (const auto& file : files) {
    std::ifstream in(file, std::ios::binary);
    const std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)),
                                           std::istreambuf_iterator<char>());
    ASSERT_EQ(bytes.size(), 160u * 120u) << file;
    int worst = 0;
    for (int y = 0; y < 120; ++y)
      for (int x = 0; x < 160; ++x) {
        const int want =
            std::min(255, (expected_dn.at<uint16_t>(y, x) + 2) / 4);  // 10 -> 8 bits, rounded
        worst = std::max(worst, std::abs(bytes[static_cast<size_t>(y) * 160 + x] - want));
      }
    EXPECT_LE(worst, 1) << file;
  }
}

TEST_F(Libcamera, V4l2ComplianceOnTheMediaNodeHasNoFailures) {
  if (!fs::exists("/usr/bin/v4l2-compliance"))
    GTEST_SKIP() << "v4l2-compliance (v4l-utils) is not installed";
  // -m tests the media node, then every node its topology names (the video node).
  auto run = run_cli(vcam("edge.json") + "v4l2-compliance -m /dev/media0");
  const auto media = run.out.find("Total for uvcvideo device /dev/media0:");
  ASSERT_NE(media, std::string::npos) << run.out << run.err;
  const std::string media_summary = run.out.substr(media, run.out.find('\n', media) - media);
  EXPECT_NE(media_summary.find("Failed: 0,"), std::string::npos) << media_summary;
  const auto grand = run.out.find("Grand Total for uvcvideo device /dev/media0:");
  ASSERT_NE(grand, std::string::npos) << run.out;
  const std::string grand_summary = run.out.substr(grand, run.out.find('\n', grand) - grand);
  EXPECT_NE(grand_summary.find("Failed: 0,"), std::string::npos) << grand_summary << "\n"
                                                                 << run.out;
  EXPECT_EQ(run.exit_code, 0) << grand_summary;
}

// libcamera's buffer path on the V4L2 node: one camera exports its buffers (EXPBUF),
// the other imports them (DMABUF) and streams into them, across the two processes'
// view of the devices (v4l2-compliance checks that QBUF reports the client's fd).
TEST_F(Libcamera, V4l2ComplianceExportsAndImportsBuffersBetweenTwoCameras) {
  if (!fs::exists("/usr/bin/v4l2-compliance"))
    GTEST_SKIP() << "v4l2-compliance (v4l-utils) is not installed";
  auto run = run_cli(vcam("edge.json", 2) + "v4l2-compliance -d /dev/video0 -e /dev/video1 -s");
  for (const char* test :
       {"test VIDIOC_EXPBUF: OK", "test DMABUF (no poll): OK", "test DMABUF (select): OK"})
    EXPECT_NE(run.out.find(test), std::string::npos) << test << "\n" << run.out;
  const auto total = run.out.find("Total for camlab-vcam device /dev/video0:");
  ASSERT_NE(total, std::string::npos) << run.out << run.err;
  const std::string summary = run.out.substr(total, run.out.find('\n', total) - total);
  EXPECT_NE(summary.find("Failed: 0,"), std::string::npos) << summary << "\n" << run.out;
}

TEST_F(Libcamera, CamlabDevicesListsTheLibcameraCamera) {
  auto run = run_cli(vcam("edge.json") + CAMLAB_CLI_PATH + " devices --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto cameras = nlohmann::json::parse(run.out);
  bool found = false;
  for (const auto& c : cameras) {
    if (c["backend"] != "libcamera") continue;
    found = true;
    EXPECT_EQ(c["transport"], "libcamera");
    EXPECT_EQ(c["name"], "vcam libcamera test");
    bool exposure = false;
    for (const auto& control : c["controls"])
      exposure |= control["name"] == "exposure_time" && control["unit"] == "us";
    EXPECT_TRUE(exposure) << c.dump(2);
  }
#ifdef CAMLAB_HAVE_LIBCAMERA
  EXPECT_TRUE(found) << run.out;
#else
  EXPECT_FALSE(found) << "built without libcamera";
#endif
}

#ifdef CAMLAB_HAVE_LIBCAMERA
// camlab's backend, run by the child: enumerate, controls with ranges, and a bracket
// at three exposures; means are of an 8-bit R8 frame of a uniform target.
TEST_F(Libcamera, BackendBracketSignalFollowsTheExposuresAsked) {
  auto run = run_cli(vcam("uniform.json") + self_executable() + " --libcamera-child");
  ASSERT_EQ(run.exit_code, 0) << run.err << run.out;
  const auto report = nlohmann::json::parse(run.out);
  ASSERT_TRUE(report["errors"].empty()) << report.dump(2);

  ASSERT_EQ(report["cameras"].size(), 1u) << report.dump(2);
  EXPECT_EQ(report["cameras"][0]["id"], "libcamera:\\_SB_.CAMLAB-1:1.0-1d6b:0102");
  EXPECT_EQ(report["cameras"][0]["name"], "vcam libcamera test");
  // ExposureTime's range is the V4L2 control's (1..200 x 100 us), in us.
  const auto& exposure = report["controls"]["exposure_time"];
  EXPECT_EQ(exposure["min"], 100);
  EXPECT_EQ(exposure["max"], 20000);
  EXPECT_EQ(exposure["default"], 5000);
  EXPECT_EQ(exposure["unit"], "us");
  EXPECT_TRUE(report["controls"].contains("analogue_gain"));
  EXPECT_EQ(report["controls"]["exposure_time_absolute"]["max"], 200);

  const auto& steps = report["bracket"];
  ASSERT_EQ(steps.size(), 3u);
  const double black_dn8 = 16.0 / 4;  // the sensor's black level in 8-bit DN
  const double base = steps[0]["mean_dn"].get<double>() - black_dn8;
  ASSERT_GT(base, 5.0) << "a measurable signal at the shortest exposure";
  for (const auto& step : steps) {
    const double ratio = step["exposure_us"].get<double>() / steps[0]["exposure_us"].get<double>();
    EXPECT_NEAR((step["mean_dn"].get<double>() - black_dn8) / base, ratio, 0.05 * ratio)
        << step.dump();
    // Metadata reports settings only when the pipeline does (UVC in libcamera 0.0.3:
    // timestamps only); when it does, it must be the exposure asked.
    if (!step["meta_exposure_us"].is_null()) {
      EXPECT_EQ(step["meta_exposure_us"], step["exposure_us"]);
    }
    EXPECT_TRUE(step["timestamps_increase"].get<bool>()) << step.dump();
  }
}

// A stream's curve is what the V4L2 format declares, as libcamera reads it: with the
// colour fields filled, the raw GREY is linear and the ISP's YUYV its sRGB; with them left
// at DEFAULT (a driver that declares nothing), libcamera gives no colour space, and the
// curve is unknown for both (capture then takes GREY's samples as linear and refuses to
// read YUYV as light), where camlab once took it as linear.
TEST_F(Libcamera, AStreamWithoutAColourSpaceHasAnUnknownCurve) {
  for (const bool declared : {true, false}) {
    SCOPED_TRACE(declared ? "declared" : "undeclared");
    nlohmann::json camera = nlohmann::json::parse(kCamera);
    camera["isp"] = {{"transfer", "srgb"}, {"declares_colour_space", declared}};
    std::ofstream(dir / "camera.json") << camera.dump();
    auto run = run_cli(vcam("uniform.json") + self_executable() + " --libcamera-child transfer");
    ASSERT_EQ(run.exit_code, 0) << run.err << run.out;
    const auto report = nlohmann::json::parse(run.out);
    ASSERT_TRUE(report["errors"].empty()) << report.dump(2);
    EXPECT_EQ(report["transfer"]["GREY"], declared ? "linear" : "unknown") << report.dump(2);
    EXPECT_EQ(report["transfer"]["YUYV"], declared ? "srgb" : "unknown") << report.dump(2);
  }
}
#endif

}  // namespace

#ifdef CAMLAB_HAVE_LIBCAMERA
namespace {

// The child: camlab's libcamera backend against the camera of this `camlab vcam run`.
// Prints {"cameras", "controls", "bracket", "errors"} as JSON on stdout; with
// `transfers_only`, {"cameras", "controls", "transfer": {fourcc: curve}, "errors"}.
int run_child(bool transfers_only) {
  using namespace camlab;
  nlohmann::json report = {{"cameras", nlohmann::json::array()},
                           {"controls", nlohmann::json::object()},
                           {"bracket", nlohmann::json::array()},
                           {"errors", nlohmann::json::array()}};
  auto finish = [&](const std::string& error) {
    if (!error.empty()) report["errors"].push_back(error);
    std::cout << report.dump() << std::endl;
    return 0;
  };
  device::DeviceRegistry registry;
  if (Status status = registry.add_libcamera(); !status) return finish(status.error().message);
  for (const auto& e : registry.devices())
    report["cameras"].push_back({{"id", e.identity.id}, {"name", e.identity.name}});
  if (registry.devices().empty()) return finish("no libcamera camera");
  auto opened = registry.open(registry.devices()[0].identity.id);
  if (!opened) return finish(opened.error().message);
  device::Camera& camera = **opened;
  auto controls = camera.controls();
  if (!controls) return finish(controls.error().message);
  for (const auto& c : *controls)
    report["controls"][c.name] = {
        {"min", c.minimum}, {"max", c.maximum}, {"default", c.default_value}, {"unit", c.unit}};
  if (transfers_only) {
    // The curve libcamera's stream configuration gives each format (camera.h's transfer).
    for (const char* fourcc : {"GREY", "YUYV"}) {
      auto configured = camera.configure({fourcc, 160, 120, 0, 0, {}});
      if (!configured) return finish(configured.error().message);
      report["transfer"][configured->fourcc] = std::string(name_of(configured->transfer));
    }
    return finish("");
  }
  auto format = camera.configure({"GREY", 160, 120, 0, 0, {}});
  if (!format) return finish(format.error().message);
  if (format->fourcc != "GREY" || format->width != 160)
    return finish("configured " + format->fourcc);
  if (Status started = camera.start(4); !started) return finish(started.error().message);
  for (int64_t exposure_us : {2000, 4000, 8000}) {
    if (auto set = camera.set_control("exposure_time", exposure_us); !set)
      return finish(set.error().message);
    // The change travels with the next request queued; then the sensor's latency (2
    // frames) and the requests already in flight (4): 10 frames settle it.
    double sum = 0;
    int kept = 0;
    int64_t last_timestamp = 0;
    bool increasing = true;
    nlohmann::json meta_exposure = nullptr;
    for (int frame = 0; frame < 14; ++frame) {
      auto f = camera.dequeue(std::chrono::milliseconds(2000));
      if (!f) return finish(f.error().message);
      increasing &= f->meta.timestamp_ns > last_timestamp;
      last_timestamp = f->meta.timestamp_ns;
      if (frame >= 10) {
        double mean = 0;
        for (size_t i = 0; i < f->size; ++i) mean += f->data[i];
        sum += mean / static_cast<double>(f->size);
        ++kept;
        if (f->meta.exposure_us) meta_exposure = *f->meta.exposure_us;
      }
      if (Status requeued = camera.requeue(*f); !requeued) return finish(requeued.error().message);
    }
    report["bracket"].push_back({{"exposure_us", exposure_us},
                                 {"mean_dn", sum / kept},
                                 {"meta_exposure_us", meta_exposure},
                                 {"timestamps_increase", increasing}});
  }
  if (Status stopped = camera.stop(); !stopped) return finish(stopped.error().message);
  return finish("");
}

}  // namespace
#endif

int main(int argc, char** argv) {
#ifdef CAMLAB_HAVE_LIBCAMERA
  if (argc > 1 && std::string(argv[1]) == "--libcamera-child")
    return run_child(argc > 2 && std::string(argv[2]) == "transfer");
#endif
  ::testing::InitGoogleTest(&argc, argv);
  return camlab::testing::run_all_tests_and_summarise();
}
