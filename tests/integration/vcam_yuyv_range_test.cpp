// YUYV frames as ffmpeg and OpenCV read them from the virtual camera carry the renderer's
// image: after the range conversion the format declares (G_FMT's quantization; DEFAULT
// maps as V4L2_MAP_QUANTIZATION_DEFAULT says, to limited range for Y'CbCr unless the
// colorspace is JPEG), the luma left and right of the edge is within 1 DN of the
// renderer's noise-free frame, and the chroma is neutral (the camera is monochrome).
// A device whose luma is not in the range it declares is off by about 13 DN on both
// sides (full-range luma read as limited).
#include <gtest/gtest.h>
#include <linux/videodev2.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "cli_runner.h"
#include "client_programs.h"

namespace {

namespace fs = std::filesystem;
using camlab::testing::run_cli;

constexpr int kWidth = 640, kHeight = 480;

struct DeclaredFormat {
  unsigned colorspace = 0, ycbcr_enc = 0, quantization = 0;
};

// Whether the declared quantization is full range (after mapping DEFAULT as the kernel
// header does for a Y'CbCr format).
bool full_range(const DeclaredFormat& f) {
  const unsigned q =
      f.quantization != V4L2_QUANTIZATION_DEFAULT
          ? f.quantization
          : static_cast<unsigned>(V4L2_MAP_QUANTIZATION_DEFAULT(false, f.colorspace, f.ycbcr_enc));
  return q == V4L2_QUANTIZATION_FULL_RANGE;
}

class VcamYuyvRange : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fs::temp_directory_path() /
          ("camlab_yuyv_" + std::to_string(::getpid()) + "_" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
    fs::create_directories(dir);
    std::ofstream(dir / "camera.json") << camlab::testing::kClientCameraJson;
    std::ofstream(dir / "scene.json") << camlab::testing::kClientSceneJson;
    truth = camlab::testing::truth_image(dir);
    ASSERT_FALSE(truth.empty());
  }
  void TearDown() override { fs::remove_all(dir); }

  std::string vcam() const {
    return "vcam run --camera " + (dir / "camera.json").string() + " --scene " +
           (dir / "scene.json").string() + " -- ";
  }

  // One YUYV frame (kWidth x kHeight, 2 bytes a pixel) against the truth.
  void check_frame(const std::string& bytes, const DeclaredFormat& format) {
    ASSERT_EQ(bytes.size(), static_cast<size_t>(kWidth * kHeight * 2));
    cv::Mat luma(kHeight, kWidth, CV_64F);
    double chroma_sum = 0;
    for (int i = 0; i < kWidth * kHeight; ++i) {
      const double y = static_cast<uint8_t>(bytes[2 * static_cast<size_t>(i)]);
      // Limited range: black at 16, white at 235.
      luma.at<double>(i / kWidth, i % kWidth) = full_range(format) ? y : (y - 16) * 255.0 / 219.0;
      chroma_sum += static_cast<uint8_t>(bytes[2 * static_cast<size_t>(i) + 1]);
    }
    const auto got = camlab::testing::means_of(luma), want = camlab::testing::means_of(truth);
    const std::string declared = full_range(format) ? "full range" : "limited range";
    EXPECT_NEAR(got.dark, want.dark, 1.0) << "dark side, read as " << declared;
    EXPECT_NEAR(got.light, want.light, 1.0) << "light side, read as " << declared;
    EXPECT_NEAR(chroma_sum / (kWidth * kHeight), 128.0, 1.0) << "a monochrome camera's chroma";
  }

  fs::path dir;
  cv::Mat truth;
};

TEST_F(VcamYuyvRange, FfmpegReadsTheRenderersLumaAfterTheDeclaredRangeConversion) {
  if (!fs::exists("/usr/bin/ffmpeg")) GTEST_SKIP() << "ffmpeg is not installed";
  if (!fs::exists("/usr/bin/v4l2-ctl")) GTEST_SKIP() << "v4l2-ctl (v4l-utils) is not installed";
  // ffmpeg's v4l2 input, frames copied out as they came (rawvideo, yuyv422: no conversion);
  // then the format the device declares for them.
  const fs::path raw = dir / "frames.yuyv";
  auto run = run_cli(vcam() +
                     "sh -c 'timeout -k 5 60 ffmpeg -hide_banner -loglevel error -f v4l2 "
                     "-input_format yuyv422 -video_size 640x480 -i /dev/video0 -frames:v 3 -f "
                     "rawvideo -pix_fmt yuyv422 -y " +
                     raw.string() + " && timeout -k 5 60 v4l2-ctl -d /dev/video0 --get-fmt-video'");
  ASSERT_EQ(run.exit_code, 0) << run.err << run.out;
  ASSERT_NE(run.out.find("'YUYV'"), std::string::npos) << run.out;
  DeclaredFormat format;
  // v4l2-ctl names the quantization: "Default (maps to Limited Range)", "Full Range", ...
  const size_t line = run.out.find("Quantization");
  ASSERT_NE(line, std::string::npos) << run.out;
  const std::string quantization = run.out.substr(line, run.out.find('\n', line) - line);
  format.quantization = quantization.find("Full Range") != std::string::npos
                            ? V4L2_QUANTIZATION_FULL_RANGE
                            : V4L2_QUANTIZATION_LIM_RANGE;
  const std::string frames = camlab::testing::read_text(raw);
  ASSERT_EQ(frames.size(), 3u * kWidth * kHeight * 2) << "three whole frames";
  check_frame(frames.substr(2u * kWidth * kHeight * 2), format);
}

TEST_F(VcamYuyvRange, OpenCvReadsTheRenderersLumaAfterTheDeclaredRangeConversion) {
  const fs::path raw = dir / "frame.yuyv";
  auto run = run_cli(vcam() + VCAM_OPENCV_YUYV_CLIENT + " " + raw.string());
  ASSERT_EQ(run.exit_code, 0) << run.err << run.out;
  DeclaredFormat format;
  unsigned width = 0, height = 0, stride = 0;
  ASSERT_EQ(std::sscanf(run.out.c_str(),
                        "width=%u height=%u bytesperline=%u colorspace=%u ycbcr_enc=%u "
                        "quantization=%u",
                        &width, &height, &stride, &format.colorspace, &format.ycbcr_enc,
                        &format.quantization),
            6)
      << run.out;
  ASSERT_EQ(width, static_cast<unsigned>(kWidth));
  ASSERT_EQ(stride, static_cast<unsigned>(kWidth * 2));
  check_frame(camlab::testing::read_text(raw), format);
}

}  // namespace
