// The capture folder: what is written is read back bit for bit, a cut-short capture is
// readable, and broken or hostile folders give specific errors.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <opencv2/core.hpp>

#include "base/atomic_file.h"
#include "image/cameramodel_file.h"
#include "image/capture_folder.h"

namespace camlab::image {
namespace {

namespace fs = std::filesystem;

class CaptureFolderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fs::temp_directory_path() /
          ("camlab_capture_" + std::to_string(::getpid()) + "_" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
  }
  void TearDown() override { fs::remove_all(dir); }

  static FrameSidecar sidecar(int bit_depth, uint64_t sequence) {
    FrameSidecar s;
    s.sequence = sequence;
    s.timestamp_ns = 1000 + static_cast<int64_t>(sequence) * 33'333'000;
    s.pixel_format = bit_depth > 8 ? "Y12" : "GREY";
    s.bit_depth = bit_depth;
    s.black_level_dn = 64;
    s.settings = {{"exposure_us", 1000.0 * (sequence + 1)}, {"focus_distance_m", INFINITY}};
    return s;
  }

  fs::path dir;
};

TEST_F(CaptureFolderTest, SixteenBitFramesRoundTripExactly) {
  auto writer = CaptureFolderWriter::create(dir, "render", {{"camera", "test"}}, {{"repeats", 1}});
  ASSERT_TRUE(writer.ok()) << writer.error().message;
  cv::Mat frames[2] = {cv::Mat(48, 64, CV_16UC1), cv::Mat(48, 64, CV_16UC1)};
  cv::RNG rng(5);
  for (int k = 0; k < 2; ++k) {
    rng.fill(frames[k], cv::RNG::UNIFORM, 0, 4096);
    ASSERT_TRUE(writer->add_frame(frames[k], sidecar(12, k)).ok());
  }
  ASSERT_TRUE(writer->finish().ok());

  auto folder = CaptureFolder::open(dir);
  ASSERT_TRUE(folder.ok()) << folder.error().message;
  EXPECT_TRUE(folder->complete());
  ASSERT_EQ(folder->frames().size(), 2u);
  for (int k = 0; k < 2; ++k) {
    auto image = folder->load_image(k);
    ASSERT_TRUE(image.ok());
    EXPECT_EQ(image->type(), CV_16UC1);
    EXPECT_EQ(cv::norm(*image, frames[k], cv::NORM_INF), 0) << "lossless";
    auto meta = folder->load_sidecar(k);
    ASSERT_TRUE(meta.ok()) << meta.error().message;
    EXPECT_EQ(meta->sequence, static_cast<uint64_t>(k));
    EXPECT_EQ(meta->bit_depth, 12);
    EXPECT_DOUBLE_EQ(meta->settings["exposure_us"].get<double>(), 1000.0 * (k + 1));
    EXPECT_TRUE(meta->settings["focus_distance_m"].is_null()) << "infinity is JSON null";
  }
}

TEST_F(CaptureFolderTest, EightBitFramesAreEightBitPngs) {
  auto writer = CaptureFolderWriter::create(dir, "single", {}, {});
  ASSERT_TRUE(writer.ok());
  cv::Mat frame(10, 10, CV_8UC1, cv::Scalar(200));
  ASSERT_TRUE(writer->add_frame(frame, sidecar(8, 0)).ok());
  // A 16-bit image for an 8-bit sidecar is a caller bug caught as an error, not a crash.
  EXPECT_FALSE(writer->add_frame(cv::Mat(10, 10, CV_16UC1), sidecar(8, 1)).ok());
  auto folder = CaptureFolder::open(dir);
  ASSERT_TRUE(folder.ok());
  EXPECT_EQ(folder->load_image(0)->type(), CV_8UC1);
}

TEST_F(CaptureFolderTest, ACaptureCutShortIsReadableAndSaysIncomplete) {
  {
    auto writer = CaptureFolderWriter::create(dir, "bracket", {}, {});
    ASSERT_TRUE(writer.ok());
    ASSERT_TRUE(writer->add_frame(cv::Mat(8, 8, CV_8UC1, cv::Scalar(1)), sidecar(8, 0)).ok());
    // No finish(): the process "died" here.
  }
  auto folder = CaptureFolder::open(dir);
  ASSERT_TRUE(folder.ok());
  EXPECT_FALSE(folder->complete());
  EXPECT_EQ(folder->frames().size(), 1u);
  EXPECT_TRUE(folder->load_image(0).ok());
  // No temporary files are left behind by the atomic writes.
  for (const auto& entry : fs::directory_iterator(dir))
    EXPECT_NE(entry.path().filename().string()[0], '.') << entry.path();
}

TEST_F(CaptureFolderTest, RefusesToOverwriteANonEmptyFolder) {
  fs::create_directories(dir);
  { std::ofstream(dir / "precious.txt") << "keep me"; }
  auto writer = CaptureFolderWriter::create(dir, "render", {}, {});
  ASSERT_FALSE(writer.ok());
  EXPECT_EQ(writer.error().code, "exists");
  EXPECT_TRUE(fs::exists(dir / "precious.txt"));
}

TEST_F(CaptureFolderTest, BrokenFoldersGiveSpecificErrors) {
  EXPECT_EQ(CaptureFolder::open(dir).error().code, "not_a_capture");
  fs::create_directories(dir);
  { std::ofstream(dir / "manifest.json") << "{ not json"; }
  EXPECT_EQ(CaptureFolder::open(dir).error().code, "bad_manifest");
  {
    std::ofstream(dir / "manifest.json")
        << R"({"format": "camlab-capture", "version": 99, "frames": []})";
  }
  EXPECT_EQ(CaptureFolder::open(dir).error().code, "unsupported_version");
  {
    std::ofstream(dir / "manifest.json") << R"({"format": "camlab-capture", "version": 1,
      "frames": [{"index": 0, "image": "../../etc/passwd", "sidecar": "a.json"}]})";
  }
  EXPECT_EQ(CaptureFolder::open(dir).error().code, "bad_manifest") << "paths must stay inside";
  {
    std::ofstream(dir / "manifest.json") << R"({"format": "camlab-capture", "version": 1,
      "frames": [{"index": 0, "image": "frame_000000.png", "sidecar": "frame_000000.json"}]})";
    std::ofstream(dir / "frame_000000.png") << "this is not a PNG";
    std::ofstream(dir / "frame_000000.json") << R"({"sequence": 0})";
  }
  auto folder = CaptureFolder::open(dir);
  ASSERT_TRUE(folder.ok());
  EXPECT_EQ(folder->load_image(0).error().code, "bad_image");
  EXPECT_EQ(folder->load_sidecar(0).error().code, "bad_sidecar");
  EXPECT_EQ(folder->load_image(5).error().code, "out_of_range");
}

TEST(CameraModelText, PrintsEveryDoubleRoundTripExact) {
  CameraModelText model;
  model.lensmodel = "LENSMODEL_OPENCV4";
  model.intrinsics = {1000.0 / 3.0, 2000.0 / 7.0, 319.5, 239.5, -0.1 / 3, 1e-17, 0, 0};
  model.imagersize = {640, 480};
  const std::string text = to_cameramodel_text(model);
  for (double value : model.intrinsics) {
    char exact[40];
    std::snprintf(exact, sizeof exact, "%.17g", value);
    EXPECT_NE(text.find(exact), std::string::npos) << exact << " missing from\n" << text;
  }
  EXPECT_NE(text.find("'extrinsics'"), std::string::npos) << "mrcal 2.2's key";
}

}  // namespace
}  // namespace camlab::image
