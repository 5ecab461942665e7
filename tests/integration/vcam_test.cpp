// `camlab vcam run`: the virtual camera as /dev/video0 for unmodified V4L2 programs
// (v4l2-ctl, camlab itself) through the LD_PRELOAD library, with no kernel support.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "cli_runner.h"

namespace {

namespace fs = std::filesystem;
using camlab::testing::run_cli;

class Vcam : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists("/usr/bin/v4l2-ctl")) GTEST_SKIP() << "v4l2-ctl (v4l-utils) is not installed";
    dir = fs::temp_directory_path() /
          ("camlab_vcam_" + std::to_string(::getpid()) + "_" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
    fs::create_directories(dir);
    // Noise-free, so every frame is exactly the renderer's expected image.
    std::ofstream(dir / "camera.json") << R"({
      "name": "vcam test",
      "sensor": {"width_px": 160, "height_px": 120, "pixel_pitch_um": 4.0, "bit_depth": 10,
                 "black_level_dn": 16, "full_well_e": 12000, "read_noise_e": 0, "shot_noise": false},
      "lens": {"focal_mm": 8.0, "f_number_min": 2.0, "f_number_max": 16.0},
      "timing": {"frame_interval_us": 20000, "control_latency_frames": 2},
      "controls": {"exposure_time_absolute": {"min": 1, "max": 200, "default": 50}}})";
    std::ofstream(dir / "scene.json") << R"({
      "illuminance_lux": 1000,
      "targets": [{"type": "slanted_edge", "size_m": [1, 1], "angle_deg": 5,
                   "pose": {"position_m": [0, 0, 2.0]}}]})";
  }
  void TearDown() override { fs::remove_all(dir); }
  std::string vcam() const {
    return "vcam run --camera " + (dir / "camera.json").string() + " --scene " +
           (dir / "scene.json").string() + " -- ";
  }
  fs::path dir;
};

TEST_F(Vcam, V4l2CtlStreamsExactlyTheRequestedFramesAndTheyAreTheRenderersImages) {
  const auto raw = dir / "frames.raw";
  auto run = run_cli(vcam() +
                     "v4l2-ctl -d /dev/video0 --set-fmt-video=pixelformat=GREY --stream-mmap "
                     "--stream-count=30 --stream-to=" +
                     raw.string());
  ASSERT_EQ(run.exit_code, 0) << run.err << run.out;
  std::ifstream in(raw, std::ios::binary);
  const std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)),
                                         std::istreambuf_iterator<char>());
  ASSERT_EQ(bytes.size(), 30u * 160 * 120) << "exactly 30 GREY frames";

  auto render = run_cli("render --camera " + (dir / "camera.json").string() + " --scene " +
                        (dir / "scene.json").string() + " --no-noise --quiet --out " +
                        (dir / "expected").string());
  ASSERT_EQ(render.exit_code, 0) << render.err;
  cv::Mat expected_dn =
      cv::imread((dir / "expected/frame_000000.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(expected_dn.type(), CV_16UC1);
  for (int frame = 0; frame < 30; ++frame) {
    int worst = 0;
    for (int y = 0; y < 120; ++y)
      for (int x = 0; x < 160; ++x) {
        const int want =
            std::min(255, (expected_dn.at<uint16_t>(y, x) + 2) / 4);  // 10 -> 8 bits, rounded
        worst = std::max(
            worst, std::abs(bytes[static_cast<size_t>(frame) * 160 * 120 + y * 160 + x] - want));
      }
    EXPECT_LE(worst, 1) << "frame " << frame;
  }
}

TEST_F(Vcam, ControlsSetInAProcessAreReadBackWithTheirRange) {
  auto run = run_cli(vcam() +
                     "v4l2-ctl -d /dev/video0 --set-ctrl exposure_time_absolute=120 "
                     "--get-ctrl exposure_time_absolute --list-ctrls");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("exposure_time_absolute: 120"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("min=1 max=200"), std::string::npos) << run.out;
}

TEST_F(Vcam, CamlabDevicesSeesTheDeviceThroughItsOwnV4l2Backend) {
  // --no-libcamera: through /dev/media0 libcamera lists the same camera too
  // (libcamera_test checks that); this test is about the V4L2 backend.
  auto run = run_cli(vcam() + CAMLAB_CLI_PATH + " devices --json --no-libcamera");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto cameras = nlohmann::json::parse(run.out);
  ASSERT_EQ(cameras.size(), 1u);
  EXPECT_EQ(cameras[0]["path"], "/dev/video0");
  EXPECT_EQ(cameras[0]["driver"], "camlab-vcam");
  EXPECT_EQ(cameras[0]["transport"], "kernel") << "to camlab it is an ordinary V4L2 device";
  bool found = false;
  for (const auto& c : cameras[0]["controls"])
    found |= c["name"] == "exposure_time_absolute" && c["max"] == 200;
  EXPECT_TRUE(found);
}

TEST_F(Vcam, V4l2ComplianceReportsNoFailures) {
  if (!fs::exists("/usr/bin/v4l2-compliance"))
    GTEST_SKIP() << "v4l2-compliance (v4l-utils) is not installed";
  // -s streams (MMAP with poll, select and epoll), -f streams every format.
  auto run = run_cli(vcam() + "v4l2-compliance -d /dev/video0 -s -f");
  const auto total = run.out.find("Total for camlab-vcam device /dev/video0:");
  ASSERT_NE(total, std::string::npos) << run.out << run.err;
  const std::string summary = run.out.substr(total, run.out.find('\n', total) - total);
  EXPECT_NE(summary.find("Failed: 0,"), std::string::npos) << summary << "\n" << run.out;
  EXPECT_EQ(run.exit_code, 0) << summary;
  // USERPTR streaming is among what it checked (the virtual device offers it, as uvcvideo).
  EXPECT_NE(run.out.find("test USERPTR (select): OK"), std::string::npos) << run.out;
}

// v4l2-ctl streaming into its own memory (USERPTR, across the broker) gets the bytes it
// gets through MMAP, frame for frame (the scene is noise-free).
TEST_F(Vcam, UserptrStreamingDeliversTheFramesMmapDoes) {
  if (!fs::exists("/usr/bin/v4l2-ctl")) GTEST_SKIP() << "v4l2-ctl (v4l-utils) is not installed";
  const std::string stream =
      "v4l2-ctl -d /dev/video0 --set-fmt-video pixelformat=GREY "
      "--stream-count 3 ";
  auto run = run_cli(vcam() + "sh -c '" + stream + "--stream-user --stream-to " +
                     (dir / "user.raw").string() + " && " + stream + "--stream-mmap --stream-to " +
                     (dir / "mmap.raw").string() + "'");
  ASSERT_EQ(run.exit_code, 0) << run.err << run.out;
  auto read_all = [](const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  const std::string user = read_all(dir / "user.raw"), mmap = read_all(dir / "mmap.raw");
  EXPECT_GT(user.size(), 0u);
  EXPECT_EQ(user.size(), mmap.size());
  EXPECT_TRUE(user == mmap) << "USERPTR frames differ from MMAP ones";
}

TEST_F(Vcam, ReturnsTheCommandsExitStatusAndRefusesBadSpecs) {
  EXPECT_EQ(run_cli(vcam() + "sh -c 'exit 7'").exit_code, 7);
  auto bad = run_cli("vcam run --camera " + (dir / "scene.json").string() + " -- true");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("camera.sensor"), std::string::npos) << bad.err;
}

}  // namespace
