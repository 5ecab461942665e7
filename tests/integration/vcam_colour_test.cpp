// The colour virtual camera end to end: unmodified programs (v4l2-compliance, ffmpeg,
// GStreamer) reading its new formats through `camlab vcam run`, and a colour aperture
// series from `camlab render` measured by `camlab analyze defocus` against the thin lens
// of each channel (written out here from the spec's numbers).
#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "cli_runner.h"

namespace {

namespace fs = std::filesystem;
using camlab::testing::run_cli;
using nlohmann::json;

// 160 x 120, 12 bits (black 64), RGGB, noise-free so that a frame's channel means are the
// truth's; QE and reflectance differ per channel so that a channel mix-up shows.
constexpr const char* kCamera = R"({
  "name": "vcam colour test",
  "sensor": {"width_px": 160, "height_px": 120, "pixel_pitch_um": 4.0, "bit_depth": 12,
             "black_level_dn": 64, "full_well_e": 20000, "read_noise_e": 0, "shot_noise": false,
             "cfa": "RGGB", "quantum_efficiency": 0.6, "quantum_efficiency_rgb": [0.45, 0.6, 0.4]},
  "lens": {"focal_mm": 8.0, "f_number_min": 1.4, "f_number_max": 16.0,
           "chromatic_focus_shift_mm": [0.02, 0.0, -0.015]},
  "timing": {"frame_interval_us": 20000},
  "controls": {"exposure_time_absolute": {"min": 1, "max": 200, "default": 40}}})";

constexpr const char* kUniformScene = R"({
  "illuminance_lux": 1000, "background_reflectance": [0.7, 0.5, 0.25],
  "targets": [{"type": "uniform", "size_m": [10, 10], "light_reflectance": [0.7, 0.5, 0.25],
               "pose": {"position_m": [0, 0, 1.0]}}]})";

bool have(const char* program) { return fs::exists(fs::path("/usr/bin") / program); }

std::vector<uint8_t> read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

class VcamColour : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fs::temp_directory_path() /
          ("camlab_vcam_colour_" + std::to_string(::getpid()) + "_" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
    fs::create_directories(dir);
    std::ofstream(dir / "camera.json") << kCamera;
    std::ofstream(dir / "scene.json") << kUniformScene;
    // What every frame's channels are: the renderer's truth (`camlab render`, noise-free).
    auto render = run_cli("render --camera " + (dir / "camera.json").string() + " --scene " +
                          (dir / "scene.json").string() + " --no-noise --quiet --out " +
                          (dir / "truth").string());
    ASSERT_EQ(render.exit_code, 0) << render.err;
    std::ifstream side(dir / "truth/frame_000000.json");
    const json truth = json::parse(side)["truth"];
    const char* names[3] = {"R", "G", "B"};
    for (int c = 0; c < 3; ++c)
      expected_dn[c] =
          truth["channels"][names[c]]["targets"][0]["expected_dn"]["light"].get<double>();
  }
  void TearDown() override { fs::remove_all(dir); }

  std::string vcam() const {
    return "vcam run --camera " + (dir / "camera.json").string() + " --scene " +
           (dir / "scene.json").string() + " -- ";
  }
  // A channel's level in an 8-bit picture made by the device's image processor.
  double level(int c) const { return (expected_dn[c] - 64) * 255.0 / (4095 - 64); }

  // R, G, B means of an RGGB mosaic of 8-bit samples.
  static std::array<double, 3> rggb_means(const uint8_t* data, int width, int height) {
    std::array<double, 3> sum{}, n{};
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        const int c = y % 2 == 0 ? (x % 2 == 0 ? 0 : 1) : (x % 2 == 0 ? 1 : 2);
        sum[c] += data[y * width + x];
        n[c] += 1;
      }
    return {sum[0] / n[0], sum[1] / n[1], sum[2] / n[2]};
  }

  // Decodes each JPEG and checks its size and channel means (MJPG at quality 90).
  void expect_jpegs(const std::vector<fs::path>& files) {
    ASSERT_FALSE(files.empty());
    for (const fs::path& file : files) {
      const cv::Mat image = cv::imread(file.string(), cv::IMREAD_COLOR);  // B, G, R
      ASSERT_FALSE(image.empty()) << file << " does not decode";
      EXPECT_EQ(image.cols, 160);
      EXPECT_EQ(image.rows, 120);
      const cv::Scalar mean = cv::mean(image);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(mean[2 - c], level(c), 1.5) << file << " " << c;
    }
  }

  fs::path dir;
  std::array<double, 3> expected_dn{};
};

TEST_F(VcamColour, V4l2ComplianceStreamsEveryFormatWithNoFailures) {
  if (!have("v4l2-compliance")) GTEST_SKIP() << "v4l2-compliance (v4l-utils) is not installed";
  // -f streams every format at every size and interval: the Bayer formats, RGB3, BGR3,
  // NV12, YUYV and MJPG. Unpaced (a frame as soon as a buffer is queued): 44 streams at
  // the frame clock take 50 s, and vcam_test covers the paced clock.
  auto run = run_cli("vcam run --unpaced --camera " + (dir / "camera.json").string() + " --scene " +
                     (dir / "scene.json").string() + " -- v4l2-compliance -d /dev/video0 -s -f");
  const auto total = run.out.find("Total for camlab-vcam device /dev/video0:");
  ASSERT_NE(total, std::string::npos) << run.out << run.err;
  const std::string summary = run.out.substr(total, run.out.find('\n', total) - total);
  EXPECT_NE(summary.find("Failed: 0,"), std::string::npos) << summary << "\n" << run.out;
  EXPECT_EQ(run.exit_code, 0) << summary;
  for (const char* format : {"Format RGGB,", "Format pRCC,", "Format NV12,", "Format MJPG,"})
    EXPECT_NE(run.out.find(std::string("test MMAP for ") + format), std::string::npos) << format;
}

TEST_F(VcamColour, FfmpegReadsMjpegFramesThatDecodeToTheScenesColour) {
  if (!have("ffmpeg")) GTEST_SKIP() << "ffmpeg is not installed";
  auto run = run_cli(vcam() +
                     "ffmpeg -hide_banner -loglevel error -f v4l2 -input_format mjpeg "
                     "-video_size 160x120 -i /dev/video0 -frames:v 3 -c copy -f image2 " +
                     (dir / "f%02d.jpg").string());
  ASSERT_EQ(run.exit_code, 0) << run.err;
  expect_jpegs({dir / "f01.jpg", dir / "f02.jpg", dir / "f03.jpg"});
}

TEST_F(VcamColour, FfmpegReadsBayerFramesWithTheRawChannelMeans) {
  if (!have("ffmpeg")) GTEST_SKIP() << "ffmpeg is not installed";
  auto run = run_cli(vcam() +
                     "ffmpeg -hide_banner -loglevel error -f v4l2 -input_format bayer_rggb8 "
                     "-video_size 160x120 -i /dev/video0 -frames:v 3 -c copy -f rawvideo " +
                     (dir / "bayer.raw").string());
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::vector<uint8_t> bytes = read_bytes(dir / "bayer.raw");
  ASSERT_EQ(bytes.size(), 3u * 160 * 120) << "three whole 8-bit frames";
  for (int frame = 0; frame < 3; ++frame) {
    const auto means = rggb_means(bytes.data() + frame * 160 * 120, 160, 120);
    // 8-bit Bayer: the top 8 of 12 bits, rounded.
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(means[c], expected_dn[c] / 16, 1.0) << c;
  }
}

TEST_F(VcamColour, GstreamerV4l2srcReadsBayerAndJpegCaps) {
  if (!have("gst-launch-1.0"))
    GTEST_SKIP() << "gst-launch-1.0 (gstreamer1.0-tools) is not installed";
  auto bayer = run_cli(vcam() +
                       "gst-launch-1.0 -q v4l2src device=/dev/video0 num-buffers=3 ! "
                       "video/x-bayer,format=rggb,width=160,height=120 ! filesink location=" +
                       (dir / "bayer.raw").string());
  if (bayer.err.find("no element \"v4l2src\"") != std::string::npos)
    GTEST_SKIP() << "GStreamer's v4l2src (gstreamer1.0-plugins-good) is not installed";
  ASSERT_EQ(bayer.exit_code, 0) << bayer.err << bayer.out;
  const std::vector<uint8_t> bytes = read_bytes(dir / "bayer.raw");
  ASSERT_EQ(bytes.size(), 3u * 160 * 120);
  const auto means = rggb_means(bytes.data(), 160, 120);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(means[c], expected_dn[c] / 16, 1.0) << c;

  auto jpeg = run_cli(vcam() +
                      "gst-launch-1.0 -q v4l2src device=/dev/video0 num-buffers=2 ! "
                      "image/jpeg,width=160,height=120 ! multifilesink location=" +
                      (dir / "g%d.jpg").string());
  ASSERT_EQ(jpeg.exit_code, 0) << jpeg.err << jpeg.out;
  expect_jpegs({dir / "g0.jpg", dir / "g1.jpg"});
}

// Image distance of a thin lens: 1 / (1/f - 1/z_o).
double image_distance(double focal_mm, double object_mm) {
  return 1.0 / (1.0 / focal_mm - 1.0 / object_mm);
}

TEST_F(VcamColour, AColourApertureSeriesGivesEachChannelsBlurAndTheChromaticFocusShift) {
  // The example colour camera (8 mm, 4 um, f_R = f + 0.02 mm, f_B = f - 0.015 mm) focused
  // at 0.5 m, an edge at 1 m: each channel's C x N = f |z_s - z_i,c| / z_i,c / pitch.
  std::ofstream(dir / "edge.json") << R"({
    "illuminance_lux": 1000, "background_reflectance": 0.18,
    "targets": [{"type": "slanted_edge", "name": "edge", "size_m": [0.2, 0.2], "angle_deg": 5,
                 "dark_reflectance": [0.08, 0.1, 0.12], "light_reflectance": [0.8, 0.75, 0.7],
                 "pose": {"position_m": [0, 0, 1.0]}}]})";
  const std::string camera =
      std::string(CAMLAB_SOURCE_DIR) + "/mock_device/examples/camera_colour_640x480.json";
  auto render = run_cli("render --camera " + camera + " --scene " + (dir / "edge.json").string() +
                        " --set focus_m=0.5 --sweep f_number=2,2.8,4,5.6,8 --quiet --out " +
                        (dir / "series").string());
  ASSERT_EQ(render.exit_code, 0) << render.err;
  auto analyze = run_cli("analyze defocus --json " + (dir / "series").string());
  ASSERT_EQ(analyze.exit_code, 0) << analyze.err;
  const json report = json::parse(analyze.out);

  // z_s: focus_m=0.5 moves the lens to the nearest 1 um step of f + z_s - f.
  const double z_s = 8.0 + std::round((image_distance(8.0, 500.0) - 8.0) / 0.001) * 0.001;
  const std::array<double, 3> focal_mm = {8.02, 8.0, 7.985};
  const char* names[3] = {"R", "G", "B"};
  std::array<double, 3> z_i{};
  for (int c = 0; c < 3; ++c) {
    z_i[c] = image_distance(focal_mm[c], 1000.0);
    const double k_truth = 8.0 * std::fabs(z_s - z_i[c]) / z_i[c] / 0.004;
    const json& fit = report["channels"][names[c]]["targets"][0]["coc_vs_aperture"];
    ASSERT_TRUE(fit.is_object()) << names[c] << ": " << report["channels"][names[c]].dump();
    const double k = fit["k_px"].get<double>();
    EXPECT_NEAR(k / k_truth - 1, 0, 0.02)
        << names[c] << ": C x N " << k << " px, thin lens " << k_truth << " px";
  }
  ASSERT_EQ(report["longitudinal_chromatic_aberration"].size(), 1u);
  const json& lca = report["longitudinal_chromatic_aberration"][0];
  // The spec's shifts are for an object at infinity; at 1 m they grow by (z_i / f)^2.
  const double want_r = z_i[0] - z_i[1], want_b = z_i[2] - z_i[1];
  EXPECT_NEAR(lca["shift_r_mm"].get<double>() / want_r - 1, 0, 0.05)
      << lca["shift_r_mm"] << " mm against " << want_r << " mm";
  EXPECT_NEAR(lca["shift_b_mm"].get<double>() / want_b - 1, 0, 0.05)
      << lca["shift_b_mm"] << " mm against " << want_b << " mm";
  EXPECT_NEAR(want_r / 0.02, 1, 0.02) << "the spec's shift, seen at 1 m";
}

}  // namespace
