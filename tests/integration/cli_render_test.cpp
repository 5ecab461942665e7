// `camlab render` end to end: a sweep becomes a capture folder whose frames carry the
// settings asked for, whose signal follows them, and whose truth is complete; bad input
// fails with a specific message and loses nothing.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "cli_runner.h"
#include "image/capture_folder.h"

namespace {

namespace fs = std::filesystem;
using camlab::testing::run_cli;

const fs::path kExamples = fs::path(CAMLAB_SOURCE_DIR) / "mock_device/examples";

class CliRender : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fs::temp_directory_path() /
          ("camlab_cli_render_" + std::to_string(::getpid()) + "_" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
    fs::create_directories(dir);
    // A small scene: one slanted edge filling the 640x480 example camera's view.
    std::ofstream(dir / "scene.json") << R"({
      "illuminance_lux": 500,
      "targets": [{"type": "slanted_edge", "size_m": [1, 1], "angle_deg": 5,
                   "pose": {"position_m": [0, 0, 1.0]}}]})";
  }
  void TearDown() override { fs::remove_all(dir); }
  std::string common() const {
    return "render --camera " + (kExamples / "camera_640x480.json").string() + " --scene " +
           (dir / "scene.json").string() + " --quiet";
  }
  fs::path dir;
};

TEST_F(CliRender, ExposureSweepWritesOneFramePerSettingWithItsSettingsAndTruth) {
  const auto out = dir / "capture";
  auto run = run_cli(common() + " --out " + out.string() +
                     " --sweep exposure_us=1000,2000,4000 --repeats 2 --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto summary = nlohmann::json::parse(run.out);
  EXPECT_EQ(summary["frames"], 6);

  auto folder = camlab::image::CaptureFolder::open(out);
  ASSERT_TRUE(folder.ok()) << folder.error().message;
  EXPECT_TRUE(folder->complete());
  EXPECT_EQ(folder->manifest()["kind"], "render");
  ASSERT_EQ(folder->frames().size(), 6u);
  double first_signal = 0;
  for (int i = 0; i < 6; ++i) {
    auto meta = folder->load_sidecar(i);
    ASSERT_TRUE(meta.ok());
    const double exposure_us = 1000.0 * (1 << (i / 2));
    EXPECT_DOUBLE_EQ(meta->settings["exposure_us"].get<double>(), exposure_us);
    EXPECT_EQ(meta->labels["repeat"], i % 2);
    EXPECT_EQ(meta->sequence, static_cast<uint64_t>(i));
    EXPECT_EQ(meta->bit_depth, 10);
    EXPECT_EQ(meta->pixel_format, "Y10");
    ASSERT_TRUE(meta->truth.is_object());
    EXPECT_TRUE(meta->truth.contains("cameramodel"));
    EXPECT_EQ(meta->truth["targets"][0]["type"], "slanted_edge");
    auto image = folder->load_image(i);
    ASSERT_TRUE(image.ok());
    const double signal = cv::mean(*image)[0] - meta->black_level_dn;
    if (i == 0) first_signal = signal;
    EXPECT_NEAR(signal / first_signal, exposure_us / 1000.0, 0.02 * exposure_us / 1000.0);
  }
  EXPECT_TRUE(fs::exists(out / "truth.cameramodel")) << "focus is constant across the sweep";
}

TEST_F(CliRender, FocusSweepChangesTheFocusDistanceInEffect) {
  const auto out = dir / "focus";
  auto run = run_cli(common() + " --out " + out.string() + " --sweep focus_m=0.5,1,2 --no-noise");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  auto folder = camlab::image::CaptureFolder::open(out);
  ASSERT_TRUE(folder.ok());
  const double asked[] = {0.5, 1.0, 2.0};
  for (int i = 0; i < 3; ++i) {
    const auto settings = folder->load_sidecar(i)->settings;
    // The motor moves in whole steps: the distance in effect is the nearest step's.
    EXPECT_NEAR(settings["focus_distance_m"].get<double>(), asked[i], 0.03 * asked[i] * asked[i]);
  }
  EXPECT_FALSE(fs::exists(out / "truth.cameramodel")) << "the model breathes with focus";
}

// --hold-exposure: each stop's time grows as N^2 from the first stop's, so the image's
// signal (H = T x E, E ~ 1 / N^2) is the same at every stop.
TEST_F(CliRender, HoldExposureGivesEveryStopTheSameSignal) {
  const auto out = dir / "held";
  auto run =
      run_cli(common() + " --out " + out.string() +
              " --set exposure_us=1000 --hold-exposure --sweep f_number=2:4:stops --no-noise");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  auto folder = camlab::image::CaptureFolder::open(out);
  ASSERT_TRUE(folder.ok());
  ASSERT_EQ(folder->frames().size(), 3u);
  double first_signal = 0;
  for (int i = 0; i < 3; ++i) {
    auto meta = folder->load_sidecar(i);
    ASSERT_TRUE(meta.ok());
    const double n = meta->settings["f_number"].get<double>();
    EXPECT_NEAR(meta->settings["exposure_us"].get<double>(), 1000 * (n / 2) * (n / 2), 1e-6) << n;
    auto image = folder->load_image(i);
    ASSERT_TRUE(image.ok());
    const double signal = cv::mean(*image)[0] - meta->black_level_dn;
    if (i == 0) first_signal = signal;
    EXPECT_NEAR(signal / first_signal, 1.0, 0.02) << "f/" << n;
  }
}

TEST_F(CliRender, BadInputFailsWithASpecificMessageAndWritesNothing) {
  struct Case {
    std::string args;
    std::string expected;
  };
  const Case cases[] = {
      {"--sweep exposure_us=1000,abc", "'abc' is not a number"},
      {"--sweep f_number=1.0,2.0", "f_number = 1.000000 is outside the lens's [1.4, 16]"},
      {"--sweep shutter=5", "unknown setting 'shutter'"},
      {"--set exposure_us=99999999", "exposure_us"},
      {"--view 7", "view 7 is not in 0..0"},
      {"--hold-exposure --sweep exposure_us=1000,2000", "it needs --sweep f_number"},
      {"--set exposure_us=20000 --hold-exposure --sweep f_number=1.4,5.6", "held for f/5.6"},
  };
  for (const auto& c : cases) {
    const auto out = dir / "never";
    auto run = run_cli(common() + " --out " + out.string() + " " + c.args);
    EXPECT_EQ(run.exit_code, 2) << c.args;
    EXPECT_NE(run.err.find(c.expected), std::string::npos) << c.args << " -> " << run.err;
    EXPECT_FALSE(fs::exists(out / "frame_000000.png")) << c.args;
    fs::remove_all(out);
  }
}

TEST_F(CliRender, RefusesToOverwriteAnExistingCapture) {
  const auto out = dir / "existing";
  fs::create_directories(out);
  std::ofstream(out / "keep.txt") << "data";
  auto run = run_cli(common() + " --out " + out.string());
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("already exists"), std::string::npos) << run.err;
  EXPECT_TRUE(fs::exists(out / "keep.txt"));
}

TEST_F(CliRender, BrokenSpecFileNamesTheFileAndTheProblem) {
  std::ofstream(dir / "broken.json") << R"({"targets": [{"type": "uniform", "size_m": [1, 1]}]})";
  auto run =
      run_cli("render --camera " + (kExamples / "camera_640x480.json").string() + " --scene " +
              (dir / "broken.json").string() + " --out " + (dir / "x").string());
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("broken.json"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("exactly one of \"pose\" or \"poses\""), std::string::npos) << run.err;
}

}  // namespace
